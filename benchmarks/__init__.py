"""Benchmarks and slow studies: plain scripts printing results (``python -m benchmarks.<name>``)."""
