"""Writing output files atomically: all of them, or (on any error) none of them.

Every output of the toolkit (compiled PDDL, formatted files, a sweep's table, pictures) goes
through here, so that an interrupted or failed command never leaves a half-written file and
never writes through a symlink or into a device.
"""

from __future__ import annotations

import errno
import os
import shutil
import stat
import tempfile
from collections.abc import Callable, Mapping
from pathlib import Path

from .errors import SSRError

#: What to write into a file: its text, or a function that writes the file at the path it is
#: given (e.g. a picture's ``save``); that path has the output's suffix, so that a writer that
#: picks its format by the suffix picks the right one.
Content = str | Callable[[str], None]


def write_atomically(path: str | Path, content: Content) -> None:
    """Write ``content`` to ``path`` through a temporary file, so nothing is left half-written."""
    write_files_atomically({Path(path): content})


def write_files_atomically(files: Mapping[str | Path, Content]) -> None:
    """Write several files as a unit: all of them, or (on any error) none of them.

    Each file goes through a temporary file beside it and is then moved in place.  Only a
    regular file is ever replaced: a symlink, FIFO, device or folder at an output path is bad
    input (an SSRError, exit 2), never written through nor replaced.  A new file gets the mode
    the umask gives (like ``open``); an existing file keeps its mode.  Filesystem errors are
    reported as SSRErrors naming the path (exit 1 for a full disk).
    """
    files = {Path(p): c for p, c in files.items()}
    for path in files:
        _check_parents(path)
        _refuse_non_regular(path)
    temps: dict[Path, str] = {}
    backups: dict[Path, str | None] = {}  # path -> hard link to its old content (None: new)
    done: list[Path] = []
    current = next(iter(files), None)  # the output being written (named by an error)
    try:
        for path, content in files.items():
            current = path
            _make_parent(path)
            suffix = ".tmp" if isinstance(content, str) else ".tmp" + path.suffix
            fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=suffix)
            temps[path] = tmp
            if isinstance(content, str):
                with os.fdopen(fd, "w", encoding="utf-8") as fh:
                    fh.write(content)
            else:
                os.close(fd)
                content(tmp)
            os.chmod(tmp, _mode_for(path))
        for path in files:
            current = path
            _refuse_non_regular(path)  # again, just before replacing
            backups[path] = _backup(path)
        for path, tmp in temps.items():
            current = path
            os.replace(tmp, path)
            done.append(path)
    except BaseException as e:
        for path in reversed(done):  # put back what was there
            old = backups.get(path)
            try:
                if old is None:
                    path.unlink()
                else:
                    os.replace(old, path)
                    backups[path] = None
            except OSError:
                pass
        for tmp in temps.values():
            Path(tmp).unlink(missing_ok=True)
        for old in backups.values():
            if old is not None:
                Path(old).unlink(missing_ok=True)
        if isinstance(e, OSError):
            raise _write_error(e, current) from None
        raise
    for old in backups.values():
        if old is not None:
            Path(old).unlink(missing_ok=True)


def check_output(path: str | Path, option: str | None = None) -> None:
    """Before the work: that :func:`write_atomically` will be able to write ``path``.

    The path must not be a symlink, folder, FIFO or device; the nearest folder above it that
    exists must be a folder in which a file (or, if folders are missing below it, a folder)
    can be created -- tried, not guessed from its mode bits, which do not bind root nor tell a
    read-only filesystem.  An SSRError (exit 2) naming the path and ``option`` otherwise, so
    that a command never runs its work only to fail at writing its result.
    """
    path = Path(path)
    said = f"{option}: " if option else ""
    _check_parents(path)
    _refuse_non_regular(path)
    folder = next((p for p in path.parents if os.path.lexists(p)), Path("."))
    try:
        if folder == path.parent:
            fd, probe = tempfile.mkstemp(dir=folder, prefix=f".{path.name}.", suffix=".probe")
            os.close(fd)
            os.unlink(probe)
        else:
            os.rmdir(tempfile.mkdtemp(dir=folder, prefix=".ssr-probe-"))
    except OSError as e:
        raise SSRError(
            f"{said}cannot write into the folder {folder} ({e.strerror or e}); "
            "choose another output path",
            file=str(path),
        ) from None


def _refuse_non_regular(path: Path) -> None:
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        return
    except OSError as e:
        raise _write_error(e, path) from None
    if stat.S_ISREG(st.st_mode):
        return
    kinds = [
        (stat.S_ISLNK, "a symbolic link"),
        (stat.S_ISDIR, "a folder"),
        (stat.S_ISFIFO, "a FIFO (named pipe)"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
    ]
    kind = next((word for test, word in kinds if test(st.st_mode)), "not a regular file")
    raise SSRError(
        f"the output path is {kind}; only a regular file is replaced "
        "(remove it or choose another output path)",
        file=str(path),
    )


def _check_parents(path: Path) -> None:
    """The nearest existing folder above ``path`` must be a folder (not a file)."""
    for parent in path.parents:
        if os.path.lexists(parent):
            if not parent.is_dir():
                raise SSRError(
                    "is not a folder (an output is to be written into it)", file=str(parent)
                )
            return


def _make_parent(path: Path) -> None:
    _check_parents(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise SSRError(
            "is not a folder (an output is to be written into it)", file=str(path.parent)
        ) from None


def current_umask() -> int:
    """The process's umask (read without changing it where /proc tells it)."""
    try:
        with open("/proc/self/status", encoding="ascii") as f:
            for line in f:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)  # no way to read it without setting it (not thread-safe)
    os.umask(mask)
    return mask


def _mode_for(path: Path) -> int:
    """An existing file's mode, or the mode ``open`` would give a new file."""
    try:
        return stat.S_IMODE(os.stat(path).st_mode)
    except FileNotFoundError:
        return 0o666 & ~current_umask()


def _backup(path: Path) -> str | None:
    """A hard link to ``path``'s present content beside it (None if there is no file)."""
    if not os.path.lexists(path):
        return None
    for i in range(100):
        name = str(path.parent / f".{path.name}.{os.getpid()}.{i}.bak")
        try:
            os.link(path, name)
            return name
        except FileExistsError:
            continue
        except OSError:  # no hard links here: a copy
            shutil.copy2(path, name)
            return name
    raise SSRError("cannot make a backup before replacing it", file=str(path))


def _write_error(e: OSError, path) -> SSRError:
    err = SSRError(f"cannot write: {e.strerror or e}", file=str(path))
    if e.errno in (errno.ENOSPC, errno.EDQUOT):
        err.exit_code = 1
    return err
