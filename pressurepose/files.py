"""Writing output files safely: atomically (temporary file renamed into place) and checked up front;
and reading a user's ``.npy`` with a message that says what is wrong with it.

Every file a verb writes goes through :func:`atomic_write` (or a wrapper here), so an interrupted or
failed write leaves the previous file, never a truncated one; and every verb checks its output paths
with :func:`check_output_path` before it starts long work.
"""

from __future__ import annotations

import errno
import json
import math
import os
import secrets
import tempfile
from pathlib import Path
from typing import Any, Callable

import numpy as np

from pressurepose.errors import BadInput, require_path

FIGURE_SUFFIXES = (".png", ".pdf", ".svg", ".jpg", ".jpeg")


def temp_name(path: Path) -> Path:
    """A hidden temporary name next to ``path`` (``.NAME.tmp-PID-HEX``), unique per call."""
    path = Path(path)
    return path.with_name(f".{path.name}.tmp-{os.getpid()}-{secrets.token_hex(4)}")


def _file_mode() -> int:
    """The permission bits a plain new file gets here (0o666 less the umask)."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def _fsync_dir(directory: Path) -> None:
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:  # some platforms cannot open directories
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def write_error(path: Path, exc: OSError) -> BadInput:
    """The BadInput for an OSError met while writing ``path`` (full disk, read-only folder...)."""
    if exc.errno in (errno.ENOSPC, errno.EDQUOT):
        return BadInput(f"no space left on the device writing {path}; finished files are kept, "
                        f"free some space and rerun the same command")
    return BadInput(f"cannot write {path}: {exc.strerror or exc}")


def stage(path: str | Path, write: Callable[[Path], Any]) -> Path:
    """First phase of an atomic write: ``write(tmp)`` to a hidden temporary file beside ``path``,
    flushed to disk. Returns the temporary path; :func:`commit` renames it onto ``path``.

    On any error the temporary file is removed and ``path`` is untouched; an OSError (full disk,
    read-only folder) becomes a :class:`BadInput` naming ``path``.
    """
    path = Path(path)
    tmp = temp_name(path)
    try:
        write(tmp)
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        # some writers (safetensors) create private 0600 files: give it a plain file's mode
        os.chmod(tmp, _file_mode())
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise write_error(path, exc) from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return tmp


def commit(tmp: Path, path: str | Path) -> None:
    """Second phase: atomically rename a staged temporary file to its final name."""
    path = Path(path)
    try:
        os.replace(tmp, path)
    except OSError as exc:
        Path(tmp).unlink(missing_ok=True)
        raise write_error(path, exc) from None
    _fsync_dir(path.parent)


def atomic_write(path: str | Path, write: Callable[[Path], Any]) -> None:
    """Call ``write(tmp)`` to write a temporary file beside ``path``, then rename it onto ``path``.

    ``path`` is replaced only once the whole file is written and flushed; on any error (Ctrl-C
    included) the temporary file is removed and ``path`` is untouched. An OSError (full disk,
    read-only folder) raises :class:`BadInput` saying so.
    """
    commit(stage(path, write), path)


def write_bytes_atomic(path: str | Path, data: bytes) -> None:
    atomic_write(path, lambda p: Path(p).write_bytes(data))


def write_text_atomic(path: str | Path, text: str) -> None:
    atomic_write(path, lambda p: Path(p).write_text(text))


def json_ready(value: Any) -> Any:
    """``value`` with numpy numbers and arrays as Python ones, tuples as lists and NaN or infinite
    floats as None: what strict JSON (no ``NaN`` / ``Infinity`` literals, which most readers refuse)
    can hold."""
    if isinstance(value, dict):
        return {k if isinstance(k, str) else str(k): json_ready(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [json_ready(v) for v in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def json_text(obj: Any, indent: int | None = 1, **dumps_kwargs) -> str:
    """``obj`` as strict JSON text (:func:`json_ready`: a NaN or infinite float becomes null)."""
    return json.dumps(json_ready(obj), indent=indent, allow_nan=False, **dumps_kwargs)


def write_json_atomic(path: str | Path, obj: Any, indent: int | None = 1) -> None:
    """``obj`` as strict JSON (:func:`json_text`), written atomically."""
    write_text_atomic(path, json_text(obj, indent=indent) + "\n")


def save_npz_atomic(path: str | Path, **arrays) -> None:
    """``np.savez_compressed`` atomically, to exactly ``path`` (numpy adds no second ``.npz``)."""
    def write(p: Path) -> None:
        with open(p, "wb") as fh:
            np.savez_compressed(fh, **arrays)

    atomic_write(path, write)


def save_figure_atomic(fig, path: str | Path, **savefig_kwargs) -> None:
    """Save a matplotlib figure atomically; the format comes from the suffix of ``path``."""
    path = Path(path)
    fmt = path.suffix.lower().lstrip(".")
    if path.suffix.lower() not in FIGURE_SUFFIXES:
        raise BadInput(f"figure path {path}: unknown image suffix {path.suffix!r}; "
                       f"use one of {', '.join(FIGURE_SUFFIXES)}")
    atomic_write(path, lambda p: fig.savefig(p, format=fmt, **savefig_kwargs))


def remove_stale_numbered(folder: str | Path, prefix: str, suffixes: tuple[str, ...], written) -> None:
    """Remove the numbered files ``<prefix><digits><suffix>`` (``mesh_000.ply``, ``estimate_1000.png``)
    in ``folder`` that are not among the paths ``written``: an earlier, longer run's, which would
    otherwise pass for this run's."""
    keep = {Path(p).name for p in written}
    for path in Path(folder).glob(f"{prefix}*"):
        number = path.name[len(prefix):]
        for suffix in suffixes:
            if number.endswith(suffix) and number[:-len(suffix)].isdigit() and path.name not in keep:
                path.unlink(missing_ok=True)


def check_output_path(path: str | Path, what: str = "output", suffixes: tuple[str, ...] | None = None,
                      directory: bool = False) -> Path:
    """Check, before any long work, that ``path`` can be written; return it as a Path.

    ``directory=True``: ``path`` is a folder that will be created if missing (a file in the way is an
    error). Otherwise ``path`` is a file: it must not be a folder, its suffix must be one of
    ``suffixes`` when given, and its parent folder must exist and be writable.
    """
    path = require_path(what, path)
    if directory:
        if path.exists() and not path.is_dir():
            raise BadInput(f"{what} {path} is a file; expected a folder (or a path that does not exist yet)")
        probe = path
        while not probe.exists():
            probe = probe.parent
        if not probe.is_dir() or not os.access(probe, os.W_OK | os.X_OK):
            raise BadInput(f"{what} {path}: cannot create or write in {probe} (not a writable folder)")
        _try_folder(path, what)
        return path
    if path.name in ("", ".", "..") or str(path).endswith(os.sep):
        raise BadInput(f"{what} {path!s} names a folder; expected a file name")
    if path.is_dir():
        raise BadInput(f"{what} {path} is a folder; expected a file name")
    if suffixes is not None and path.suffix.lower() not in suffixes:
        raise BadInput(f"{what} {path}: expected a file ending in {' or '.join(suffixes)}")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise BadInput(f"{what} {path}: folder {parent} does not exist")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise BadInput(f"{what} {path}: folder {parent} is not writable")
    if path.exists() and not os.access(path, os.W_OK) and not os.access(parent, os.W_OK):
        raise BadInput(f"{what} {path} exists and is not writable")
    return path


def _try_folder(path: Path, what: str) -> None:
    """Create ``path`` and a file in it, then remove what was created: some folders pass a permission
    check and still refuse (``/proc``, ``/sys``, read-only mounts)."""
    created = []
    probe = path
    while not probe.exists():
        created.append(probe)
        probe = probe.parent
    try:
        for folder in reversed(created):
            folder.mkdir()
        fd, name = tempfile.mkstemp(dir=path, prefix=".pressurepose-probe-")
        os.close(fd)
        os.unlink(name)
    except OSError as exc:
        raise BadInput(f"{what} {path}: cannot create or write in this folder ({exc.strerror or exc})") from None
    finally:
        for folder in created:
            try:
                folder.rmdir()
            except OSError:
                pass


def read_npy(path: str | Path, what: str) -> np.ndarray:
    """A numeric array from a ``.npy`` file; BadInput naming ``what`` for a missing, empty, text,
    truncated or pickled file."""
    path = Path(path)
    if not path.is_file():
        raise BadInput(f"{what} file {str(path)!r} does not exist")
    check_npy_header(path, what)
    try:
        arr = np.load(path, allow_pickle=False)
    except (ValueError, OSError, EOFError) as exc:
        raise BadInput(f"{what} file {str(path)!r} is not a readable .npy file "
                       f"({numpy_load_problem(path, exc)})") from None
    if arr.dtype.kind not in "fiub":
        raise BadInput(f"{what} file {str(path)!r} holds {arr.dtype} values; expected numbers")
    return arr


def check_npy_header(path: str | Path, what: str) -> None:
    """BadInput unless ``path`` starts with a ``.npy`` header whose array fits in the file: an ``.npz``
    under a ``.npy`` name, or a header claiming more data than the file holds (which numpy would try
    to allocate first), is refused by name before anything is read."""
    path = Path(path)
    try:
        with open(path, "rb") as fh:
            if fh.read(2) == b"PK":
                raise BadInput(f"{what} file {str(path)!r} is an .npz archive under another name; expected one "
                               f"array saved with numpy.save (or name it .npz)")
            fh.seek(0)
            try:
                version = np.lib.format.read_magic(fh)
                shape, _, dtype = (np.lib.format.read_array_header_1_0(fh) if version == (1, 0)
                                   else np.lib.format.read_array_header_2_0(fh))
            except (ValueError, OSError, EOFError, SyntaxError):
                return  # np.load names the problem
            data_bytes = path.stat().st_size - fh.tell()
    except OSError as exc:
        raise BadInput(f"{what} file {str(path)!r} cannot be read ({exc})") from None
    if dtype.hasobject:
        return  # refused by allow_pickle=False
    need = int(np.prod(shape, dtype=object)) * dtype.itemsize
    if need > data_bytes:
        raise BadInput(f"{what} file {str(path)!r} claims an array of shape {tuple(shape)} ({need} bytes) but "
                       f"holds {data_bytes} bytes of data: truncated or corrupt")


def numpy_load_problem(path: str | Path, exc: Exception) -> str:
    """What is wrong with a file ``np.load(allow_pickle=False)`` refused: numpy calls anything without
    a .npy / .npz header "pickled data", which misleads for an empty or a text file."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(6)
    except OSError as err:
        return str(err)
    if not head:
        return "the file is empty"
    if head != b"\x93NUMPY" and not head.startswith(b"PK"):
        if "allow_pickle" in str(exc) and head[:1] in (b"\x80", b"("):
            return "it holds pickled Python objects, which are not read"
        return "it has no .npy / .npz header (write it with numpy.save / numpy.savez)"
    return str(exc)


def stored_dataset(f, name: str, what: str):
    """The dataset ``name`` of an open HDF5 file ``f``, stored in that file. BadInput naming ``what``
    when it is missing or a group, or is not data of this file: a soft link (dangling or not), an
    external link, a virtual dataset or external storage (the last three read other files)."""
    import h5py

    link = f.get(name, getlink=True)
    if link is None:
        raise BadInput(f"{what} has no dataset {name!r} (has: {', '.join(f.keys())})")
    if isinstance(link, h5py.ExternalLink):
        raise BadInput(f"{what}: {name!r} is an external link to {link.path!r} in {link.filename!r}; only data "
                       f"stored in the file itself is read")
    if isinstance(link, h5py.SoftLink):
        target = "a missing object" if f.get(name) is None else "another object"
        raise BadInput(f"{what}: {name!r} is a soft link to {link.path!r} ({target}); expected the dataset itself")
    obj = f[name]
    if not isinstance(obj, h5py.Dataset):
        raise BadInput(f"{what}: {name!r} is a group; expected a dataset")
    if obj.is_virtual or obj.external:
        kind = "a virtual dataset mapped from" if obj.is_virtual else "a dataset whose data lies in"
        raise BadInput(f"{what}: {name!r} is {kind} other files; only data stored in the file itself is read")
    return obj


def load_npz(path: str | Path, what: str, fields=None) -> dict[str, np.ndarray]:
    """The arrays of an ``.npz`` (all, or those named in ``fields``, which must all be there), read
    without pickle. Anything else (missing, empty, truncated, corrupt, not an .npz, pickled, lacking
    a field) is a BadInput naming ``what`` and the file."""
    import zipfile
    import zlib

    p = Path(path)
    try:
        z = np.load(p, allow_pickle=False)
        if not isinstance(z, np.lib.npyio.NpzFile):
            raise BadInput(f"{what} {str(p)!r} holds one array; expected an .npz of named arrays")
        with z:
            missing = [k for k in (fields or ()) if k not in z.files]
            if missing:
                raise BadInput(f"{what} {str(p)!r} lacks {', '.join(missing)} (has: {', '.join(z.files)})")
            return {k: z[k] for k in (fields or z.files)}
    except BadInput:
        raise
    except (zipfile.BadZipFile, zlib.error) as exc:
        raise BadInput(f"{what} {str(p)!r} is corrupt ({type(exc).__name__}: {exc})") from None
    except (OSError, ValueError, EOFError, KeyError) as exc:
        raise BadInput(f"{what} {str(p)!r} is not a readable .npz ({numpy_load_problem(p, exc)})") from None
