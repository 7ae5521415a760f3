"""The package's one progress contract. A long computation takes ``progress``: None, or a callable
``progress(done, total)`` called in the calling thread with ``done`` growing from 0 to ``total`` (items, pairs or
blends; ``total`` is constant within one call); it returns True to cancel, None or False to go on. What a cancel
does is the computation's to document: the index loops stop and keep what they have, matrices and blends raise
``errors.Cancelled``. ``Counter`` reports units that finish several at a time; ``Bar`` is the one adapter to a tqdm
bar on stderr (the command line and the evaluation). A stage that wants to name its item knows its own list."""

import sys
import time

from .errors import Cancelled

__all__ = ["Cancelled", "wants_cancel", "check", "Counter", "Bar"]


def wants_cancel(progress, done, total) -> bool:
    """Report ``(done, total)`` to ``progress`` (None: nothing); True when it returned True (cancel)."""
    return progress is not None and progress(done, total) is True


def check(progress, done, total):
    """Report ``(done, total)``; raise Cancelled when ``progress`` returned True."""
    if wants_cancel(progress, done, total):
        raise Cancelled()


class Counter:
    """Units done out of ``total``: ``add(n)`` reports the running count to ``progress`` and raises Cancelled
    when it asks to stop."""

    def __init__(self, progress, total):
        self.progress, self.total, self.done = progress, int(total), 0

    def add(self, n=1):
        self.done += int(n)
        check(self.progress, self.done, self.total)


class Bar:
    """``progress(done, total)`` drawn as a tqdm bar on stderr titled ``desc``; a silent callable when ``enabled``
    is False, when tqdm is missing, or for fewer than two units. The bar appears once the work has gone on for
    ``DELAY`` seconds (a warm query, every entry a cache hit, draws none and never imports tqdm; a bar that
    ``total`` opens at once is drawn at once). Never cancels. Use as a context manager (or ``close``)."""

    DELAY = 0.5  # seconds: tqdm's own ``delay`` idea, without importing tqdm for work that ends sooner

    def __init__(self, desc, enabled=True, total=None):
        self.desc, self.enabled, self._bar, self._done, self._since = desc, enabled, None, 0, None
        if total is not None:
            self._open(total)

    def _open(self, total):
        if not self.enabled or total is None or total < 2:
            self.enabled = False
            return
        try:
            from tqdm import tqdm
        except ImportError:  # pragma: no cover - tqdm is a dev requirement
            self.enabled = False
            return
        self._bar = tqdm(total=total, desc=self.desc, file=sys.stderr, leave=False, dynamic_ncols=True)

    def __call__(self, done, total):
        if self._bar is None and self.enabled:
            now = time.monotonic()
            self._since = now if self._since is None else self._since
            if now - self._since < self.DELAY or done >= total:
                return
            self._open(total)
        if self._bar is not None and done > self._done:
            self._bar.update(done - self._done)
            self._done = done

    def close(self):
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False
