"""The MCAP log: `McapLogWriter` records a running monitor, `read_log` reads it back (crash-cut files too).

Reader API for audits::

    from discern.monitor.log import read_log, RecoveryReport
    report = RecoveryReport()
    for rec in read_log(["run1/", "other.mcap"], report):
        if rec.kind == "verdict": ...   # rec.verdict is a discern.rules.verdict.Verdict
    print(report.summary())
"""

from .channels import STATUS_TOPIC, RejectedInput, parse_topic, vehicle_topic
from .reader import FileRecovery, LogRecord, RecoveryReport, first_log_time_ns, log_files, log_metadata, read_log
from .writer import LOG_NAME, McapLogWriter

__all__ = [
    "FileRecovery",
    "LOG_NAME",
    "LogRecord",
    "McapLogWriter",
    "RecoveryReport",
    "RejectedInput",
    "STATUS_TOPIC",
    "first_log_time_ns",
    "log_files",
    "log_metadata",
    "parse_topic",
    "read_log",
    "vehicle_topic",
]
