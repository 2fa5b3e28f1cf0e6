"""Keeping the signals that interrupt a render (SIGINT, SIGTERM, SIGHUP) out of work that must
not be cut in half: the import of a C extension (numpy reports a Ctrl-C during its import as an
ImportError), the start of a local Dask cluster (a cluster interrupted while its workers start
cannot be closed, and Dask's exit hook then prints a traceback)."""
import contextlib
import signal
import threading

INTERRUPTING = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


@contextlib.contextmanager
def signals_held():
    """The signals wait (blocked) until the block ends, then arrive as usual. Threads started in
    the block (numpy's OpenBLAS workers) keep them blocked, so they still reach the main thread.
    Processes started in the block would inherit the mask: use signals_deferred there."""
    if not hasattr(signal, "pthread_sigmask") or threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, INTERRUPTING)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


@contextlib.contextmanager
def signals_deferred():
    """The signals are noted, not handled, until the block ends; then the first one noted is
    raised again, to the handler in place after the block. Processes started in the block
    inherit nothing of this (handlers are reset when a process executes a program). A signal
    ignored stays ignored."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    noted = []
    previous = {signum: signal.signal(signum, lambda signum, frame: noted.append(signum))
                for signum in INTERRUPTING if signal.getsignal(signum) is not signal.SIG_IGN}
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
    if noted:
        signal.raise_signal(noted[0])
