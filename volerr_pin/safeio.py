"""Files as databases write them, and requests sized before they are allocated.

Every file the product writes goes through this module:

* :func:`check_outputs` is called before any work. It refuses an output that is an input
  (the same file by path, link or hard link), that is a folder or a device, whose folder does
  not exist or cannot be written, or that another output of the same run also names.
* :func:`replacing` (and :func:`write_text`) writes to a temporary file in the target's own
  folder, flushes it to disk and renames it over the target only when the writing succeeded.
  A run that fails leaves every existing file as it was and no temporary file behind.
* :func:`keep_backup` keeps the file a successful run replaces, for the writers whose
  outputs people edit by hand (machine specs).

:func:`require_memory` refuses, before allocating, a request that cannot fit in the memory
the machine has free, naming the parameter that sets its size.
"""

from __future__ import annotations

import contextlib
import os
import stat
import tempfile
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path

from .errors import InputError

__all__ = ["available_memory", "check_outputs", "keep_backup", "replacing", "require_memory", "same_file",
           "write_text"]

#: fraction of the free memory one request may take
MEMORY_SHARE = 0.5


def same_file(a: str | os.PathLike, b: str | os.PathLike) -> bool:
    """Whether two paths name the same file: the same resolved path, or (both existing) the
    same inode through a link or hard link."""
    pa, pb = Path(a), Path(b)
    if os.path.realpath(pa) == os.path.realpath(pb):
        return True
    try:
        return os.path.samefile(pa, pb)
    except OSError:
        return False


def check_outputs(outputs: Mapping[str, str | os.PathLike | None],
                  inputs: Iterable[str | os.PathLike | None] = ()) -> dict[str, Path]:
    """Check the files a run will write, before it does any work.

    Parameters
    ----------
    outputs : mapping of str to path or None
        The parameter that names each output (``"output"``, ``"png"``) and its path; None
        (not asked for) is skipped.
    inputs : iterable of path or None
        Every file the run reads (data, program, machine spec and URDF); None is skipped.

    Returns
    -------
    dict of str to Path
        The outputs asked for, by parameter.

    Raises
    ------
    InputError
        Naming the parameter, if an output is empty, is an input, is a folder or not a
        regular file, lies in a folder that does not exist or cannot be written, or is named
        by two parameters.
    """
    inputs = [Path(p) for p in inputs if p is not None]
    checked: dict[str, Path] = {}
    for name, value in outputs.items():
        if value is None:
            continue
        text = os.fspath(value)
        if not text.strip():
            raise InputError(f"{name}: empty file name", parameters=(name,))
        path = Path(text)
        for source in inputs:
            if same_file(path, source):
                raise InputError(f"{name}: {path} is an input of this run ({source}); write the result "
                                 "elsewhere", parameters=(name,))
        for other, taken in checked.items():
            if same_file(path, taken):
                raise InputError(f"{name}: {path} is also given as {other}", parameters=(name, other))
        if path.is_dir():
            raise InputError(f"{name}: {path} is a folder; give a file name", parameters=(name,))
        if path.exists() and not stat.S_ISREG(path.stat().st_mode):
            raise InputError(f"{name}: {path} exists and is not a regular file", parameters=(name,))
        folder = path.parent
        if not folder.is_dir():
            raise InputError(f"{name}: {path}: folder {folder} does not exist", parameters=(name,))
        if not os.access(folder, os.W_OK | os.X_OK):
            raise InputError(f"{name}: {path}: folder {folder} is not writable", parameters=(name,))
        if path.exists() and not os.access(path, os.W_OK):
            raise InputError(f"{name}: {path} exists and is read-only", parameters=(name,))
        checked[name] = path
    return checked


def _mode_for(target: Path) -> int:
    """The permissions a new file gets (those of the file it replaces, else 0666 less the umask)."""
    try:
        return stat.S_IMODE(target.stat().st_mode)
    except FileNotFoundError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


def _fsync_folder(folder: Path) -> None:
    with contextlib.suppress(OSError):
        fd = os.open(folder, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


@contextlib.contextmanager
def replacing(target: str | os.PathLike, *, backup: bool = False) -> Iterator[Path]:
    """A temporary path beside ``target`` to write; renamed over ``target`` when the block ends
    without an exception, removed when it raises.

    The temporary name keeps the target's suffix, so writers that choose a format by suffix
    (matplotlib, Rerun) write the right one.

    Parameters
    ----------
    target : path
        The file to write.
    backup : bool, optional
        Keep an existing ``target`` as a numbered backup (:func:`keep_backup`) when it is
        replaced.

    Yields
    ------
    Path
        The temporary file to write (it exists, empty).
    """
    target = Path(target)
    folder = target.parent
    fd, name = tempfile.mkstemp(prefix=f".{target.name}.", suffix=f".part{target.suffix}", dir=folder)
    os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        os.chmod(tmp, _mode_for(target))
        if backup:
            keep_backup(target)
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
        raise
    _fsync_folder(folder)


def write_text(target: str | os.PathLike, text: str, *, backup: bool = False, newline: str | None = None) -> Path:
    """Write ``text`` (UTF-8) to ``target`` through a temporary file (:func:`replacing`).

    Parameters
    ----------
    target : path
        The file to write.
    text : str
        Its content.
    backup : bool, optional
        Keep a replaced file as a numbered backup.
    newline : str, optional
        As for :func:`open`; ``""`` writes line ends unchanged.

    Returns
    -------
    Path
        ``target``.
    """
    target = Path(target)
    with replacing(target, backup=backup) as tmp:
        with open(tmp, "w", encoding="utf-8", newline=newline) as fh:
            fh.write(text)
    return target


def keep_backup(target: str | os.PathLike) -> Path | None:
    """Keep an existing file as ``<stem>.bak.<suffix>``, or ``<stem>.bak2.<suffix>`` and so on
    when that is taken (a backup is never overwritten), before it is replaced. The backup keeps
    the suffix, so a backed-up spec still loads.

    Parameters
    ----------
    target : path
        The file about to be replaced.

    Returns
    -------
    Path or None
        The backup, or None when ``target`` does not exist.
    """
    target = Path(target)
    if not target.exists():
        return None
    for k in range(1, 10_000):
        backup = target.with_name(f"{target.stem}.bak{'' if k == 1 else k}{target.suffix}")
        try:
            os.link(target, backup)  # atomic, and the target stays in place until it is replaced
            return backup
        except FileExistsError:
            continue
        except OSError:  # no hard links on this file system: copy
            if backup.exists():
                continue
            import shutil

            shutil.copy2(target, backup)
            return backup
    raise InputError(f"{target}: 9,999 backups exist already; remove some")


def available_memory() -> int:
    """Bytes of memory this process may still allocate: the system's available memory
    (``MemAvailable``), or less when an address-space limit is set."""
    free = None
    with contextlib.suppress(OSError, ValueError):
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    free = int(line.split()[1]) * 1024
                    break
    if free is None:
        try:
            free = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (ValueError, OSError, AttributeError):
            free = 8 << 30
    with contextlib.suppress(ImportError, OSError, ValueError):
        import resource

        soft, _ = resource.getrlimit(resource.RLIMIT_AS)
        if soft != resource.RLIM_INFINITY:
            free = min(free, soft)
    return free


def _size(nbytes: float) -> str:
    for unit, factor in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if nbytes >= factor:
            return f"{nbytes / factor:.3g} {unit}"
    return f"{nbytes:.0f} bytes"


def require_memory(nbytes: float, what: str, parameters: tuple[str, ...] = ()) -> None:
    """Refuse a request that would take more than half of the free memory.

    Parameters
    ----------
    nbytes : float
        The estimated peak memory of the request.
    what : str
        What needs it, e.g. ``"a table of 2000^3 nodes"``.
    parameters : tuple of str
        The parameters that set the size; the message names them.

    Raises
    ------
    InputError
        If ``nbytes`` exceeds :data:`MEMORY_SHARE` of :func:`available_memory`.
    """
    free = available_memory()
    if nbytes > MEMORY_SHARE * free:
        hint = f"; reduce {', '.join(parameters)}" if parameters else ""
        raise InputError(f"{what} needs about {_size(nbytes)} of memory, more than this machine can "
                         f"spare ({_size(free)} free){hint}", parameters=parameters)
