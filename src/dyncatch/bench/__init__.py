"""Throughput measurements (results go to docs/performance.md, never into timed tests)."""
