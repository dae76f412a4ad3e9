"""Which reasoning code decided: a log records it next to the catalog's digest.

The catalog is not all that makes a verdict: the facts a scene becomes (rules/facts.py), the sanity layer's
window (sanity/window.py) and the proofs are code. A replay by other code may change verdicts with the same
rules, and the audit says so rather than report those changes as the rules'.
"""

from __future__ import annotations

import hashlib
from functools import lru_cache
from importlib import resources

REASONING_PACKAGES = ("discern.rules", "discern.sanity")


@lru_cache(maxsize=None)
def reasoning_code_digest() -> str:
    """A digest of the Python sources of the rules and sanity packages: the same code, the same digest."""
    digest = hashlib.blake2b(digest_size=8)
    for package in REASONING_PACKAGES:
        root = resources.files(package)
        for source in sorted((p for p in root.iterdir() if p.name.endswith(".py")), key=lambda p: p.name):
            digest.update(f"{package}.{source.name}\0".encode() + source.read_bytes() + b"\0")
    return digest.hexdigest()
