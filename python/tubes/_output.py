"""The one rule for every file the Python tools write (the C program's, src/io/tubes_main.c):

- the target is a regular file or does not exist yet (a symbolic link: the file it names); a
  directory, FIFO, device node or socket is refused before any work, and left untouched;
- the content is written to FILE.tmp.<pid> in the same directory and renamed over FILE when
  complete, so FILE is either the old file or the whole new one, never a part;
- on any failure (a full disk, a signal, KeyboardInterrupt, an exception in the caller) the
  temporary file is removed and OutputError carries one message with the system's reason
  (strerror); the tools print it and exit with EXIT_IO = 3.

HDF5 files and figures are made in memory (h5py on an io.BytesIO, matplotlib into bytes) and
written here with ordinary writes: a full disk is then an OSError from os.write, never a failure
inside HDF5. (h5py writing to a full disk directly fails in the middle of HDF5's metadata flush:
the file is left half-closed, h5py prints an "Exception ignored" traceback per open object, and
HDF5's exit handler then walks the half-closed file and the interpreter dies of SIGSEGV at exit,
the FILE.tmp.<pid> left behind; the C program avoids the same crash with H5dont_atexit.)
docs/experiment.md, "Output files: the writer rule".
"""
from __future__ import annotations

import contextlib
import io
import os
import stat

EXIT_IO = 3   # an output that could not be written (the C program's code)


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised where the program is (handle_sigterm), so that a temporary file is removed
    as on Ctrl-C; exit status 128 + 15."""
    status = 143


def handle_sigterm() -> None:
    """SIGTERM raises Terminated (the default would end the process with FILE.tmp.<pid> left)."""
    import signal

    def raise_terminated(signum, frame):
        raise Terminated()
    signal.signal(signal.SIGTERM, raise_terminated)


def interrupted(exc: BaseException, prog: str) -> int:
    """The message and exit status for Ctrl-C (130) or SIGTERM (143)."""
    import sys
    sig = "SIGTERM" if isinstance(exc, Terminated) else "SIGINT"
    print(f"{prog}: interrupted ({sig}); no output file was written", file=sys.stderr)
    return getattr(exc, "status", 130)


class OutputError(OSError):
    """An output file refused or not written: the message names the file (and the option) and
    the reason; nothing was left behind. An OSError, as the errors of the writers were before."""


def _kind(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return "a directory"
    if stat.S_ISFIFO(mode):
        return "a FIFO"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def _label(path: str, option: str | None) -> str:
    return f"{option} '{path}'" if option else f"the output '{path}'"


def check_target(path, option: str | None = None) -> str:
    """The file to write for the output path (option, e.g. '-o', names it in messages): path
    itself, or the file a symbolic link names. Raises OutputError when it is a directory, FIFO,
    device or socket, a link to nothing, or in a directory that does not exist. Call it before
    the work, so that a refusal costs nothing and leaves the target untouched."""
    path = os.fspath(path)
    what = _label(path, option)
    if not path:
        raise OutputError(f"{option or 'the output'}: an empty file name; give the name of a regular file")
    target = path
    if os.path.islink(path):
        if not os.path.exists(path):
            raise OutputError(f"{what} is a symbolic link to nothing that exists: give the name of a regular file")
        target = os.path.realpath(path)
    try:
        st = os.stat(target)
    except FileNotFoundError:
        d = os.path.dirname(target) or "."
        if not os.path.isdir(d):
            raise OutputError(f"cannot write {what}: its directory '{d}' does not exist") from None
        _check_directory(target, what)
        return target
    except OSError as exc:
        raise OutputError(f"cannot write {what}: {exc.strerror}") from None
    if not stat.S_ISREG(st.st_mode):
        raise OutputError(f"{what} is {_kind(st.st_mode)}: give the name of a regular file (it was left untouched)")
    _check_directory(target, what)      # the temporary file is made there, then renamed
    return target


def _check_directory(target: str, what: str) -> None:
    d = os.path.dirname(target) or "."
    if not os.access(d, os.W_OK | os.X_OK):
        raise OutputError(f"cannot write {what}: no permission to create files in its directory '{d}'")


def _remove(tmp: str) -> None:
    with contextlib.suppress(OSError):
        os.remove(tmp)


@contextlib.contextmanager
def atomic_path(path, option: str | None = None):
    """Yields a temporary path PATH.tmp.<pid> in PATH's directory for the caller to write; renamed
    over PATH when the block ends normally, removed on any exception (KeyboardInterrupt
    included). An OSError (the block's or the rename's) becomes OutputError with the system's
    reason; other exceptions pass through unchanged, the temporary file removed."""
    path = os.fspath(path)
    target = check_target(path, option)
    tmp = f"{target}.tmp.{os.getpid()}"
    try:
        os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o666))
    except OSError as exc:
        raise OutputError(f"cannot create {_label(path, option)} (via '{tmp}'): {exc.strerror}") from None
    try:
        yield tmp
        os.replace(tmp, target)
    except OutputError:
        _remove(tmp)
        raise
    except OSError as exc:
        _remove(tmp)
        raise OutputError(f"writing {_label(path, option)} failed: {exc.strerror or exc}; "
                          "no output file was left") from None
    except BaseException:
        _remove(tmp)
        raise


def _write_all(fd: int, data: bytes) -> None:
    view = memoryview(data)
    while view:
        n = os.write(fd, view)
        view = view[n:]


def write_files(items, option: str | None = None) -> None:
    """Write several outputs [(path, bytes, option), ...] (or (path, bytes)) all or none: every
    target checked, every temporary file written and synced, then all renamed. On a failure
    before the renames none of the targets is touched."""
    with contextlib.ExitStack() as stack:
        staged = []
        for item in items:
            path, data = item[0], item[1]
            opt = item[2] if len(item) > 2 else option
            staged.append((os.fspath(path), opt, stack.enter_context(atomic_path(path, opt)), data))
        for path, opt, tmp, data in staged:
            try:
                fd = os.open(tmp, os.O_WRONLY | os.O_TRUNC)
                try:
                    _write_all(fd, data)
                    os.fsync(fd)
                finally:
                    os.close(fd)
            except OSError as exc:
                raise OutputError(f"writing {_label(path, opt)} failed: {exc.strerror or exc}; "
                                  "no output file was left") from None


def write_bytes(path, data: bytes, option: str | None = None) -> None:
    """Write one output file by the rule above."""
    write_files([(path, data)], option)


def h5_image(fill) -> bytes:
    """An HDF5 file made in memory: fill(h5py.File) writes its content; returns the file's bytes."""
    import h5py
    buf = io.BytesIO()
    with h5py.File(buf, "w") as f:
        fill(f)
    return buf.getvalue()


def check_figure_format(path, option: str | None = None) -> str:
    """The format of a figure file from its suffix (png without one); OutputError naming the
    formats allowed when matplotlib cannot write it. Before the work, as check_target."""
    from matplotlib.backend_bases import FigureCanvasBase
    fmt = os.path.splitext(os.fspath(path))[1][1:].lower() or "png"
    allowed = FigureCanvasBase.get_supported_filetypes()
    if fmt not in allowed:
        raise OutputError(f"{_label(os.fspath(path), option)}: matplotlib cannot write .{fmt} files; "
                          f"give one of .{', .'.join(sorted(allowed))}")
    return fmt


def figure_image(fig, path, **kw) -> bytes:
    """A matplotlib figure's bytes in the format of path's suffix (png when it has none)."""
    fmt = os.path.splitext(os.fspath(path))[1][1:].lower() or "png"
    buf = io.BytesIO()
    fig.savefig(buf, format=fmt, **kw)
    return buf.getvalue()


class _Batch:
    def __init__(self):
        self.items = []


_BATCH: list = []    # the open batches (save_figure appends to the innermost)


@contextlib.contextmanager
def batch():
    """Within the block save_figure only collects; at its normal end every file is written all or
    none (write_files); on an exception nothing is written."""
    b = _Batch()
    _BATCH.append(b)
    try:
        yield b
    finally:
        _BATCH.remove(b)
    if _BATCH:                  # nested: the outer batch writes them
        _BATCH[-1].items.extend(b.items)
    else:
        write_files(b.items)


def out_dir(path, option: str | None = None):
    """The directory path for output files, made with its parents if missing; OutputError when
    it is something else or cannot be made."""
    import pathlib
    d = pathlib.Path(path)
    if d.exists() and not d.is_dir():
        raise OutputError(f"{_label(os.fspath(path), option)} is not a directory: give a directory for the figures")
    try:
        d.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"cannot make the directory {_label(os.fspath(path), option)}: {exc.strerror}") from None
    return d


def emit(path, data: bytes, option: str | None = None) -> None:
    """Write data into path by the rule above, or add it to the open batch."""
    check_target(path, option)
    if _BATCH:
        _BATCH[-1].items.append((path, data, option))
    else:
        write_bytes(path, data, option)


def save_figure(fig, path, option: str | None = None, **kw) -> None:
    """fig into path by the rule above (or into the open batch); the target is checked first."""
    check_target(path, option)
    emit(path, figure_image(fig, path, **kw), option)
