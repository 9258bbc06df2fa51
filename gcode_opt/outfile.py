"""Safe output files: checked before the work, written beside the target, put in place at once.

``check_writable(path, what)`` runs before any work: the folder exists and is writable, the
path is not a folder, an existing file can be replaced.  ``AtomicOutput(path)`` gives a
temporary file ``.gcode-opt-*.tmp`` beside the *target* (a symlink is resolved, so the
link stays a link and its target is what changes) and ``commit()`` puts it in place:

* an ordinary file: ``os.replace`` -- atomic; a reader sees the old file or the new one.
* a hard-linked file (st_nlink > 1): the new bytes are copied over the old inode so every
  name keeps pointing at the same, updated file.  Not atomic, so it is made as safe as a copy
  can be: the temporary file is complete and synced first; ``posix_fallocate`` reserves the
  new size up front (a full disk or ``ulimit -f`` fails there, before a byte of the original
  changes); SIGINT/SIGTERM/SIGHUP are held back during the copy.  A power cut during the copy
  is the one window left: the complete temporary file is removed only after the copy is synced.
* mode is kept (a new file gets 0666 minus the umask); owner and group are kept where the
  user may set them.

Signals: ``install_signal_handlers()`` turns SIGTERM and SIGHUP into ``Interrupted`` (SIGINT
is already KeyboardInterrupt), so the ``finally`` blocks remove the temporary file; SIGXFSZ
is ignored, so ``ulimit -f`` surfaces as an EFBIG error instead of killing the process.
"""
from __future__ import annotations

import errno
import os
import stat

try:            # the C module signal wraps: the same calls, on signal numbers, without the enum
    import _signal as signal        # classes signal builds at its import (~3 M instructions a run)
except ImportError:                 # pragma: no cover - an interpreter without it
    import signal

TMP_PREFIX = ".gcode-opt-"
TMP_SUFFIX = ".tmp"
COMMITTED: list[str] = []      # targets replaced in this process (an interrupt after this is not "unchanged")
PENDING: set[str] = set()      # temporary files made and not yet put in place or removed


def _discard(tmp):
    try:
        os.unlink(tmp)
    except OSError:
        pass
    PENDING.discard(tmp)


def discard_pending() -> None:
    """Remove every temporary file still pending: main() calls it on its way out, so an
    interrupt that lands between a file's creation and its with block (or inside its
    cleanup) leaves nothing behind either."""
    for tmp in list(PENDING):
        _discard(tmp)
_DEFERRED = tuple(getattr(signal, n) for n in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, n))


class OutputError(OSError):
    """An output path that cannot be written; str() is 'PATH: why'."""

    def __str__(self):
        return self.args[0] if self.args else "output error"


class Interrupted(BaseException):
    """SIGTERM / SIGHUP arrived (BaseException, like KeyboardInterrupt: nothing swallows it)."""

    def __init__(self, signum):
        super().__init__(signum)
        self.signum = signum


def install_signal_handlers() -> dict:
    """Returns the previous handlers, for restore_signal_handlers (main() may run inside
    another program, e.g. the test runner)."""
    def handler(signum, frame):
        raise Interrupted(signum)
    saved = {}
    for name, h in (("SIGTERM", handler), ("SIGHUP", handler), ("SIGXFSZ", signal.SIG_IGN)):
        if hasattr(signal, name):
            sig = getattr(signal, name)
            try:
                saved[sig] = signal.signal(sig, h)
            except ValueError:           # not the main thread: leave signals to the host program
                break
    return saved


def restore_signal_handlers(saved: dict):
    for sig, h in saved.items():
        signal.signal(sig, h if h is not None else signal.SIG_DFL)


def target_of(path: str) -> str:
    """The file that writing `path` changes: symlinks followed, absolute."""
    return os.path.realpath(path)


def check_writable(path: str, what: str = "output") -> None:
    """Raise OutputError('PATH: why') unless `path` can be created or replaced."""
    target = target_of(path)
    if os.path.isdir(target):
        raise OutputError(f"{path}: is a directory; give a file name for the {what}")
    folder = os.path.dirname(target) or "."
    if not os.path.isdir(folder):
        raise OutputError(f"{path}: folder {folder} does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise OutputError(f"{path}: folder {folder} is not writable")
    if os.path.exists(target) and not os.access(target, os.W_OK):
        # os.replace would succeed in a writable folder, but a read-only file is a statement
        raise OutputError(f"{path}: file is read-only")


def describe(e: OSError, path: str) -> str:
    """'PATH: cannot write: why' for a failed write (disk full, size limit, ...)."""
    why = {errno.ENOSPC: "no space left on the device", errno.EFBIG: "file too large (size limit, ulimit -f)",
           errno.EDQUOT: "disk quota exceeded", errno.EACCES: "permission denied",
           errno.EROFS: "read-only file system"}.get(e.errno, e.strerror or str(e))
    return f"{path}: cannot write: {why}"


def _umask() -> int:
    m = os.umask(0)
    os.umask(m)
    return m


# tempfile's own flags for its files; tempfile is not imported here (with shutil, bz2, lzma
# and random it is ~10 M instructions a run)
_TMP_FLAGS = os.O_RDWR | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)
_NAME_CHARS = "abcdefghijklmnopqrstuvwxyz0123456789_"


def _mkstemp(folder, tries=10000):
    """tempfile.mkstemp(prefix=TMP_PREFIX, suffix=TMP_SUFFIX, dir=folder): (fd, absolute
    path) of a new file made 0600 with O_EXCL under a random 8-character name, another
    name tried while one exists."""
    for _ in range(tries):
        name = "".join(_NAME_CHARS[b % 37] for b in os.urandom(8))
        path = os.path.abspath(os.path.join(folder, TMP_PREFIX + name + TMP_SUFFIX))
        try:
            return os.open(path, _TMP_FLAGS | os.O_CREAT, 0o600), path
        except FileExistsError:
            continue
    raise FileExistsError(errno.EEXIST, "No usable temporary file name found")


def unnamed_file(folder=None):
    """An unbuffered binary file with no name in folder (default: the temporary folder), as
    tempfile.TemporaryFile(dir=folder, buffering=0) makes it on Linux (O_TMPFILE); tempfile
    itself where O_TMPFILE is missing or refused."""
    o_tmpfile = getattr(os, "O_TMPFILE", 0)
    if o_tmpfile:
        where = folder or next((d for d in map(os.environ.get, ("TMPDIR", "TEMP", "TMP")) if d), "/tmp")
        try:
            return open(os.open(where, _TMP_FLAGS | o_tmpfile, 0o600), "w+b", buffering=0)
        except OSError:
            pass
    import tempfile
    return tempfile.TemporaryFile(dir=folder, buffering=0)


class AtomicOutput:
    """with AtomicOutput(out) as o: write o.tmp ...; o.commit()   -- the temporary file is
    removed on any exit that did not commit."""

    def __init__(self, path: str):
        self.path = path
        self.target = target_of(path)
        self.tmp = None
        self.committed = False

    def __enter__(self):
        folder = os.path.dirname(self.target) or "."
        # the file is made and registered with the signals held back: a signal in between
        # would leave a file that neither __exit__ (the with block has not begun) nor
        # discard_pending knows of
        old = signal.pthread_sigmask(signal.SIG_BLOCK, _DEFERRED) if _DEFERRED else None
        try:
            try:
                fd, self.tmp = _mkstemp(folder)
            except OSError as e:
                raise OutputError(describe(e, self.path)) from None
            PENDING.add(self.tmp)
            os.close(fd)
        finally:
            if old is not None:
                signal.pthread_sigmask(signal.SIG_SETMASK, old)   # a held-back signal fires here
        return self

    def __exit__(self, et, ev, tb):
        if self.tmp and not self.committed:
            _discard(self.tmp)
        return False

    def commit(self):
        """Put the finished temporary file in place of the target."""
        old = signal.pthread_sigmask(signal.SIG_BLOCK, _DEFERRED) if _DEFERRED else None
        try:
            try:
                st = os.stat(self.target)
            except FileNotFoundError:
                st = None
            if st is not None and st.st_nlink > 1 and stat.S_ISREG(st.st_mode):
                self._copy_over()
            else:
                self._replace(st)
            self.committed = True
        except OSError as e:
            if isinstance(e, OutputError):
                raise
            raise OutputError(describe(e, self.path)) from None
        finally:
            if self.committed:
                COMMITTED.append(self.target)
            if old is not None:
                signal.pthread_sigmask(signal.SIG_SETMASK, old)   # a held-back signal fires here

    def _replace(self, st):
        if st is not None:
            os.chmod(self.tmp, stat.S_IMODE(st.st_mode))
            try:
                os.chown(self.tmp, st.st_uid, st.st_gid)
            except (PermissionError, AttributeError):
                pass                     # only root may give a file away; the mode is kept anyway
        else:
            os.chmod(self.tmp, 0o666 & ~_umask())
        os.replace(self.tmp, self.target)
        PENDING.discard(self.tmp)
        self.tmp = None

    def _copy_over(self):
        size = os.path.getsize(self.tmp)
        with open(self.tmp, "rb") as src, open(self.target, "r+b") as dst:
            if size and hasattr(os, "posix_fallocate"):
                try:
                    os.posix_fallocate(dst.fileno(), 0, size)    # ENOSPC / EFBIG now, not half-way
                except OSError as e:
                    if e.errno not in (errno.EOPNOTSUPP, errno.EINVAL, getattr(errno, "ENOTSUP", -1)):
                        raise
            while True:
                buf = src.read(1 << 20)
                if not buf:
                    break
                dst.write(buf)
            dst.truncate(size)
            dst.flush()
            os.fsync(dst.fileno())
        _discard(self.tmp)
        self.tmp = None
