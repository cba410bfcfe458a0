"""Benchmarks of the web tool: ``live`` (sessions in a real browser), ``upload`` (terrain uploads),
``headless`` (how a headless chromium is driven).
"""

from __future__ import annotations
