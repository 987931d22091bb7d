"""Files as databases write them, and requests sized before they are allocated.

Every file the product writes goes through this module:

* :func:`check_outputs` is called before any work. It refuses an output that is an input
  (the same file by path, link or hard link), that is a folder or a device, whose folder does
  not exist or cannot be written, whose name the file system cannot take, or that another
  output of the same run also names.
* :func:`replacing` (and :func:`write_text`) writes to a temporary file in the target's own
  folder, flushes it to disk and renames it over the target only when the writing succeeded.
  A run that fails leaves every existing file as it was and no temporary file behind.
* :func:`transaction` does the same for all the outputs of one run together: all are
  written or none.
* :func:`read_text` reads an input file whole only when it is a regular file that fits in
  memory, as UTF-8 (naming line, column and byte where it is not).
* :func:`keep_backup` keeps the file a successful run replaces, for the writers whose
  outputs people edit by hand (machine specs).

:func:`require_memory` refuses, before allocating, a request that cannot fit in the memory
the machine has free, naming the parameter that sets its size.
"""

from __future__ import annotations

import contextlib
import json
import os
import stat
import tempfile
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path

from ._errors import InputError

__all__ = ["READ_OVERHEAD", "Transaction", "available_memory", "check_output_folder", "check_outputs", "keep_backup",
           "replacing", "require_memory", "read_json", "read_text", "same_file", "transaction", "write_text"]

#: fraction of the free memory one request may take
MEMORY_SHARE = 0.5


def same_file(a: str | os.PathLike, b: str | os.PathLike) -> bool:
    """Whether two paths name the same file: the same resolved path, or (both existing) the
    same inode through a link or hard link.

    Parameters
    ----------
    a, b : path
        The two paths.

    Returns
    -------
    bool
        True when writing one would change the other.
    """
    pa, pb = Path(a), Path(b)
    if os.path.realpath(pa) == os.path.realpath(pb):
        return True
    try:
        return os.path.samefile(pa, pb)
    except OSError:
        return False


#: the longest file name (bytes) assumed where the file system does not say
NAME_MAX = 255


def name_max(folder: str | os.PathLike) -> int:
    """The longest file name (bytes) the file system of ``folder`` takes (:data:`NAME_MAX`
    where it does not say or the folder does not exist)."""
    try:
        return int(os.pathconf(folder, "PC_NAME_MAX"))
    except (OSError, ValueError):
        return NAME_MAX


def _check_name(name: str, part: str, folder: str | os.PathLike, what: str) -> None:
    """Refuse, naming the parameter ``name``, a ``what`` ("file", "folder") name ``part`` longer
    than the file system of ``folder`` takes."""
    size, limit = len(os.fsencode(part)), name_max(folder)
    if size > limit:
        raise InputError(f"{name}: {part[:24]}...: a {what} name of {size} bytes; this file system takes at most "
                         f"{limit}", parameters=(name,))


def _fitted(head: str, room: int) -> str:
    """``head`` cut (by whole characters) to at most ``room`` bytes of the file system's encoding."""
    while head and len(os.fsencode(head)) > room:
        head = head[:-1]
    return head


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
        try:
            _check_output(name, path, inputs, checked)
        except OSError as exc:  # a name the file system cannot take (too long, a loop of links)
            raise InputError(f"{name}: {path}: {exc.strerror or exc}", parameters=(name,)) from None
        checked[name] = path
    return checked


def _check_output(name: str, path: Path, inputs: list[Path], checked: dict[str, Path]) -> None:
    """One output of :func:`check_outputs` (raises InputError, or OSError from the file system)."""
    _check_name(name, path.name, path.parent, "file")
    for source in inputs:
        if same_file(path, source):
            also = "" if os.fspath(path) == os.fspath(source) else f" ({source})"
            raise InputError(f"{name}: {path} is an input of this run{also}; write the result elsewhere",
                             parameters=(name,))
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


def check_output_folder(name: str, folder: str | os.PathLike | None) -> Path | None:
    """Check a folder a run will write files into, before it does any work: an existing
    folder that can be written, or one that can be made (its nearest existing parent is a
    writable folder).

    Parameters
    ----------
    name : str
        The parameter that names the folder.
    folder : path or None
        The folder; None (not asked for) is skipped.

    Returns
    -------
    Path or None
        The folder.

    Raises
    ------
    InputError
        Naming the parameter, if the path is a file, or the folder cannot be made or written.
    """
    if folder is None:
        return None
    path = Path(folder)
    if not os.fspath(folder).strip():
        raise InputError(f"{name}: empty folder name", parameters=(name,))
    try:
        existing = path
        while not existing.exists() and existing != existing.parent:
            existing = existing.parent
        if not existing.is_dir():
            raise InputError(f"{name}: {existing} is not a folder", parameters=(name,))
        if not os.access(existing, os.W_OK | os.X_OK):
            raise InputError(f"{name}: {existing} is not writable", parameters=(name,))
        for part in path.relative_to(existing).parts if existing != path else ():  # the folders to make
            _check_name(name, part, existing, "folder")
    except OSError as exc:  # a name the file system cannot take (too long, a loop of links)
        raise InputError(f"{name}: {path}: {exc.strerror or exc}", parameters=(name,)) from None
    return path


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


#: checks every commit makes before it renames anything: one that raises refuses the commit (and
#: the transaction removes its temporary files). The command line adds one that raises a
#: termination signal whose exception a callback swallowed (Python ignores exceptions raised in
#: weakref callbacks, where a signal handler may happen to run).
COMMIT_CHECKS: list = []


class Transaction:
    """Outputs of one run, written to temporary files beside their targets and renamed over
    them together when the run succeeds (:func:`transaction`).

    A writer is given :meth:`path` instead of its target; paths the writer reports back can
    be turned into the targets with :meth:`final`.
    """

    def __init__(self):
        self._pending: list[tuple[Path, Path, bool]] = []  # (temporary, target, keep a backup)
        self._made: list[Path] = []   # folders made for the outputs, parents first
        #: the backups kept of replaced files, once committed
        self.backups: list[Path] = []

    def folder(self, path: str | os.PathLike) -> Path:
        """Make the folder ``path`` (and its missing parents) for outputs; the folders made are
        removed again if the run fails, so a refused or failed run leaves no empty folder.

        Parameters
        ----------
        path : path
            The folder.

        Returns
        -------
        Path
            The folder.
        """
        path = Path(path)
        missing = []
        probe = path
        while not probe.exists() and probe != probe.parent:
            missing.append(probe)
            probe = probe.parent
        path.mkdir(parents=True, exist_ok=True)
        self._made.extend(reversed(missing))
        return path

    def target_of(self, temporary: str | os.PathLike) -> Path | None:
        """The target a temporary path of this transaction stands for.

        Parameters
        ----------
        temporary : path
            A path :meth:`path` handed out (or any other).

        Returns
        -------
        Path or None
            Its target; None for a path this transaction did not hand out.
        """
        for tmp, target, _ in self._pending:
            if str(tmp) == str(temporary):
                return target
        return None

    def path(self, target: str | os.PathLike, *, backup: bool = False) -> Path:
        """A temporary file beside ``target`` (empty, hidden, with exactly its suffix - none
        where it has none - and a name the file system takes) that replaces it on commit.

        Parameters
        ----------
        target : path
            The file the run writes.
        backup : bool, optional
            Keep an existing ``target`` as a numbered backup (:func:`keep_backup`).

        Returns
        -------
        Path
            The temporary file to write.
        """
        target = Path(target)
        if target.suffix:
            head, sep, suffix = target.name, ".", f".part{target.suffix}"
        else:  # no dot after the leading one, or the temporary file would have a suffix its target has not
            head, sep, suffix = target.name.replace(".", "_"), "-", "-part"
        # within the name limit: the leading dot, the separator and mkstemp's 8 random characters
        head = _fitted(head, name_max(target.parent) - len(os.fsencode(suffix)) - 10)
        fd, name = tempfile.mkstemp(prefix=f".{head}{sep}", suffix=suffix, dir=target.parent)
        os.close(fd)
        self._pending.append((Path(name), target, backup))
        return Path(name)

    def final(self, value):
        """A report with every temporary path said as its target.

        Parameters
        ----------
        value : dict, list, tuple, str or Path
            The report (nested dicts and lists of strings, paths and other values).

        Returns
        -------
        same type as ``value``
            The report with the temporary paths this transaction handed out replaced by their
            targets.
        """
        names = {str(tmp): str(target) for tmp, target, _ in self._pending}
        if isinstance(value, dict):
            return {k: self.final(v) for k, v in value.items()}
        if isinstance(value, (list, tuple)):
            return type(value)(self.final(v) for v in value)
        if isinstance(value, (str, Path)) and str(value) in names:
            return type(value)(names[str(value)])
        return value

    def commit(self) -> None:
        """Flush every temporary file to disk and rename it over its target (after
        :data:`COMMIT_CHECKS`)."""
        for check in COMMIT_CHECKS:
            check()
        for tmp, target, _ in self._pending:
            with open(tmp, "rb+") as fh:
                os.fsync(fh.fileno())
            os.chmod(tmp, _mode_for(target))
        for tmp, target, backup in self._pending:
            kept = keep_backup(target) if backup else None
            if kept is not None:
                self.backups.append(kept)
            os.replace(tmp, target)
        for folder in {target.parent for _, target, _ in self._pending}:
            _fsync_folder(folder)
        self._pending.clear()
        self._made.clear()

    def abort(self) -> None:
        """Remove every temporary file and the folders made for the outputs; the targets stay
        as they were."""
        for tmp, _, _ in self._pending:
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()
        self._pending.clear()
        for folder in reversed(self._made):
            with contextlib.suppress(OSError):   # not empty: something else wrote there meanwhile
                folder.rmdir()
        self._made.clear()


@contextlib.contextmanager
def transaction() -> Iterator[Transaction]:
    """Outputs that are all written or none: the block writes to :meth:`Transaction.path`
    files; they replace their targets when it ends without an exception, and are removed
    when it raises.

    Yields
    ------
    Transaction
        Hands out the temporary paths.
    """
    tx = Transaction()
    try:
        yield tx
        tx.commit()
    except OSError as err:
        tx.abort()
        raise _named(err, tx) from None
    except BaseException:
        tx.abort()
        raise


def _named(err: OSError, tx: Transaction) -> OSError:
    """An error writing outputs, naming the output (not its hidden temporary file)."""
    if err.filename is None:   # a full disk says no file: the outputs being written
        target = ", ".join(str(t) for _, t, _ in tx._pending) or None
    else:
        target = tx.target_of(err.filename)
    return OSError(err.errno, err.strerror, str(target) if target is not None else err.filename)


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
    with transaction() as tx:
        yield tx.path(target, backup=backup)


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
    limit = name_max(target.parent)
    for k in range(1, 10_000):
        mark = f".bak{'' if k == 1 else k}{target.suffix}"
        backup = target.with_name(_fitted(target.stem, limit - len(os.fsencode(mark))) + mark)
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
    """Bytes of memory this process may still allocate.

    Returns
    -------
    int
        The system's available memory (``MemAvailable``), or less when an address-space limit
        is set.
    """
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


#: bytes of memory reading a text file takes per byte of file, at most (the text, its lines
#: or cells, the values parsed from them), for the check before a file is read whole
READ_OVERHEAD = 20


def _line_and_column(data: bytes, offset: int) -> tuple[int, int]:
    """1-based line and character column of a byte offset (the bytes before it are UTF-8)."""
    start = data.rfind(b"\n", 0, offset) + 1
    return data.count(b"\n", 0, offset) + 1, len(data[start:offset].decode("utf-8", "replace")) + 1


def read_text(path: str | os.PathLike, error: type[Exception] = InputError, what: str = "file") -> str:
    """The text of a file that a user names: a regular file, small enough for the memory the
    machine has free, UTF-8 (a byte-order mark is dropped), without NUL bytes.

    Every input file is read through here, so that a device, a pipe, a folder, a file larger
    than memory allows or a file in another encoding is refused with one line naming it
    before any of it is read.

    Parameters
    ----------
    path : str or path
        The file.
    error : type, default InputError
        Exception class raised (``SpecError`` for specs, ``MeasurementError`` for measurement
        files); constructed with the message.
    what : str
        What the file is, for messages ("spec", "measurement file").

    Returns
    -------
    str
        The text; line ends as in the file.

    Raises
    ------
    InputError
        (or ``error``) If the file cannot be read, is not a regular file, would need more
        than half of the free memory, is not UTF-8 (naming line, column and byte) or holds
        a NUL byte.
    """
    path = Path(path)
    try:
        info = path.stat()
    except OSError as err:
        raise error(f"{path}: cannot read {what}: {err.strerror}") from None
    if stat.S_ISDIR(info.st_mode):
        raise error(f"{path}: is a folder, not a {what}")
    if not stat.S_ISREG(info.st_mode):
        raise error(f"{path}: not a regular file (a device, pipe or socket); give a {what}")
    try:
        require_memory(info.st_size * READ_OVERHEAD, f"{path}: reading this {what} of {info.st_size:,} bytes")
    except InputError as err:
        raise error(str(err)) from None
    try:
        data = path.read_bytes()
    except OSError as err:
        raise error(f"{path}: cannot read {what}: {err.strerror}") from None
    try:
        content = data.decode("utf-8")
    except UnicodeDecodeError as err:
        line, column = _line_and_column(data, err.start)
        raise error(f"{path}:{line}:{column}: not UTF-8 text (byte 0x{data[err.start]:02x} at offset "
                    f"{err.start}); save the {what} as UTF-8") from None
    if b"\x00" in data:
        line, column = _line_and_column(data, data.index(b"\x00"))
        raise error(f"{path}:{line}:{column}: a NUL byte; this is not a text file")
    return content.removeprefix("\ufeff")


class _Duplicate(Exception):
    def __init__(self, key: str, first, second):
        super().__init__(key)
        self.key, self.first, self.second = key, first, second


def _unique_keys(pairs: list) -> dict:
    out: dict = {}
    for key, value in pairs:
        if key in out:
            raise _Duplicate(key, out[key], value)
        out[key] = value
    return out


def _no_constant(name: str):
    raise ValueError(name)


def read_json(path: str | os.PathLike, error: type[Exception] = InputError, what: str = "JSON report"):
    """A JSON file that a user names, read by a spec's rules: through :func:`read_text`, with
    one value under one key, finite numbers only, and nesting Python can read.

    Parameters
    ----------
    path : str or path
        The file.
    error : type, default InputError
        Exception class raised, constructed with the message.
    what : str
        What the file is, for messages.

    Returns
    -------
    object
        The parsed JSON.

    Raises
    ------
    InputError
        (or ``error``) Naming the file: what :func:`read_text` refuses; text that is not JSON
        (naming line and column); a key given twice in one object (the later would win
        without a word); ``NaN`` or ``Infinity`` (not JSON, though Python writes them); or
        arrays and objects nested deeper than Python's recursion allows.
    """
    text = read_text(path, error, what)
    try:
        return json.loads(text, object_pairs_hook=_unique_keys, parse_constant=_no_constant)
    except json.JSONDecodeError as err:
        raise error(f"{path}:{err.lineno}:{err.colno}: not JSON: {err.msg}") from None
    except _Duplicate as dup:
        raise error(f"{path}: key {dup.key!r} is given twice in one object ({_brief(dup.first)} and "
                    f"{_brief(dup.second)}); keep one") from None
    except ValueError as err:
        raise error(f"{path}: {err} is not a JSON number; a {what} holds finite numbers only") from None
    except RecursionError:
        raise error(f"{path}: arrays or objects nested too deep to read; this is not a {what}") from None


def _brief(value) -> str:
    text = json.dumps(value)
    return text if len(text) <= 40 else text[:37] + "..."
