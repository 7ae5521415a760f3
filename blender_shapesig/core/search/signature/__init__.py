"""The signature search (sim^n, eq. 9.1 of the thesis): a clip's log-signature direction, word codes and sketch
(``words``) in an ``IndexEntry`` (``entry``); the ranking itself is ``core.search.rank``'s. See docs/search.md.
"""
