"""The local search, the default engine ("Motion and pose"): key-point features of a canonical body posed like the
clip (``features``), their windows' log-signatures as the first stage and a DTW of the key points as the second
(``dtw``), the same take across files (``take``), entries in the store (``store``), the library file of a large
library (``library``), the query from an action (``action``) and the ranking through the store (``rank``). See
docs/search.md.
"""
