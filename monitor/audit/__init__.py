"""Offline audit of the monitor's MCAP logs: disagreements, aggregates, reports, and replay against new rules."""
