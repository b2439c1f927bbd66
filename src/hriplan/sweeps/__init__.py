"""Sweeps and batches: many variants of a task planned exactly as `hriplan plan` would.

variants (what to vary, one validated task per variant) -> engines (local worker processes or
Ray actors, each keeping a planning session per robot) -> results (append-safe Parquet, resumed
by variant key) -> report (maps of success and separation over the varied parameters).
"""
