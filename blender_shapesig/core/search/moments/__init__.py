"""Moments: every window of a take that matches a query, not whole clips (``windows``). See docs/search.md,
"Moments".
"""
