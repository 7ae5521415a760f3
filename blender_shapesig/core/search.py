"""Signature index and ranking (issue 7). Planned API:

  rank_clips(query, library, metric="sim", level=None, rerank=0, top=None, cache=None) -> list[RankResult]
  RankResult(name, distance, elastic, frames)
  SignatureCache(path)  # on-disk cache keyed by a hash of the clip data
"""
