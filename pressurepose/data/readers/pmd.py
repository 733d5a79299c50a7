"""PhysioNet "A Pressure Map Dataset for In-bed Posture Classification" (PMD 1.0.0; Pouyan,
Birjandtalab, Heydarzadeh, Nourani, Ostadabbas, IEEE BHI 2017; Open Data Commons Attribution).

Experiment I (Vista Medical FSA SoftFlex 2048 mat, 64 x 32, raw 0-1000, mat preset
``fsa_softflex_2048``)::

    subject-info-i.csv        Subject-Number, Age, Height/cm, Weight/kg (no sex recorded)
    S<n>/<posture>.txt        one frame a line: 2048 tab-separated readings, row-major 64 x 32,
                              row 0 at the head end; the first frames can be blank (start-up)

Postures (file number): 1 supine, 2 right side, 3 left side, 4-5 right 30 / 60 deg (wedge), 6-7
left 30 / 60 deg, 8 supine star, 9 supine hands crossed, 10 supine knee up, 11 / 12 supine right /
left knee up, 13 right fetal, 14 left fetal, 15-17 supine with the bed's head raised 30, 45, 60 deg
('inclined': not a flat bed, not scored). 'right' and 'left' are read as the side the person lies
on (the clinical "right lateral" position). The columns then need no flip: in the right-side
images (2 and 13) the knees lie toward higher columns than the hips (26 of 26; in the left-side
images 3 and 14, 24 of 26 toward lower columns; ``benchmarks/bench_real.py``), as a body lying on
its right side faces +x in the project's bed frame (a supine body's left side toward column 0).
Images alone cannot tell a mirrored mat from swapped labels; this rests on that reading of the
labels.

Experiment II (BodiTrak BT3510 mat, 27 x 64, raw 0-500; each file the average of about 20
frames; two mattresses; the FEET at row 0, flipped here)::

    subject-info-ii.csv                     UTF-16 text: subject, height, weight (columns by name)
    S<n>/{Sponge,Air}_Mat/Matrix_{Sponge,Air}_<letter><k>.txt   64 lines of 27 space-separated values

Posture letters (the dataset's description; :func:`pmd_ii_posture`): B1-B10 supine with different
arm and leg positions; C1-C3 and D1-D3 lying on one side and on the other ('lateral': which letter is
which side is not certain, so either side counts); E1-E6 turned part-way onto a side on a support
('lateral', and ``detail`` names a wedge: scored as turned toward either side and summarised apart,
as PMD-I's wedge postures are, :func:`pressurepose.eval.real.is_wedge`); F1-F6 supine variations;
F7 supine with the head of the bed raised ('inclined': not scored, as PMD-I's 15-17); G1-G3
unlabelled extras (''). A file with another letter is kept unscored, with a warning that counts
them. This layout is built from the dataset's description alone (the project keeps experiment II
apart as an independent test).
"""

from __future__ import annotations

import csv
import io
import re
import warnings
from pathlib import Path

import numpy as np

from pressurepose.data.readers.images import RealImages, check_person, make_real
from pressurepose.data.realprep import combine_frames, orient, valid_frames
from pressurepose.errors import FLOAT32_MAX, BadInput
from pressurepose.mat import get_mat

PMD_I_POSTURES: dict[int, tuple[str, str]] = {
    1: ("supine", "supine"), 2: ("right", "right side"), 3: ("left", "left side"),
    4: ("right", "right 30 deg (wedge)"), 5: ("right", "right 60 deg (wedge)"),
    6: ("left", "left 30 deg (wedge)"), 7: ("left", "left 60 deg (wedge)"),
    8: ("supine", "supine star"), 9: ("supine", "supine hands crossed"), 10: ("supine", "supine knee up"),
    11: ("supine", "supine right knee up"), 12: ("supine", "supine left knee up"),
    13: ("right", "right fetal"), 14: ("left", "left fetal"),
    15: ("inclined", "supine, bed head 30 deg"), 16: ("inclined", "supine, bed head 45 deg"),
    17: ("inclined", "supine, bed head 60 deg"),
}
# letter -> (posture label, description): module docstring
PMD_II_LETTERS: dict[str, tuple[str, str]] = {
    "B": ("supine", "supine, arm and leg variation"),
    "C": ("lateral", "side lying (one side)"),
    "D": ("lateral", "side lying (the other side)"),
    "E": ("lateral", "turned part-way onto a side, propped (as on a wedge)"),
    "F": ("supine", "supine variation"),
    "G": ("", "unlabelled extra"),
}
PMD_II_INCLINED = ("F", 7)  # F7: the head of the bed raised
PMD_I_SHAPE, PMD_II_SHAPE = (64, 32), (64, 27)


def _read_text(path: Path, encoding: str = "utf-8") -> str:
    if not path.is_file():
        raise BadInput(f"{path} is {'a folder' if path.is_dir() else 'missing'}; expected a text file")
    try:
        return path.read_text(encoding=encoding)
    except (OSError, UnicodeError) as exc:
        raise BadInput(f"{path}: cannot read as {encoding} text ({exc})") from None


def read_subject_info(path: str | Path, encoding: str = "utf-8") -> dict[str, dict]:
    """{subject number as str: {'height_m', 'weight_kg', 'gender'}} from a PMD subject file.

    Columns are found by name (one containing 'subject', 'height', 'weight', optionally 'sex' or
    'gender'); the height's unit is the one its header names (m, cm or mm, as in ``Height/cm``),
    else heights above 3 are taken as cm. Comma, semicolon or tab separated. BadInput naming the
    file, the line and the subject for a subject that is not a whole number or is listed twice, and
    for a height or weight outside :data:`~.images.HEIGHT_RANGE_M` / :data:`~.images.WEIGHT_RANGE_KG`
    (NaN included)."""
    path = Path(path)
    text = _read_text(path, encoding).lstrip("\ufeff")
    lines = [ln for ln in text.splitlines() if ln.strip()]
    if not lines:
        raise BadInput(f"{path} is empty; expected a header and one row per subject")
    delim = max(",;\t", key=lines[0].count)
    rows = list(csv.reader(io.StringIO("\n".join(lines)), delimiter=delim))
    header = [h.strip().lower() for h in rows[0]]

    def find(*keys, required=True):
        for i, h in enumerate(header):
            if any(k in h for k in keys):
                return i
        if required:
            raise BadInput(f"{path}: no {'/'.join(keys)} column in the header {rows[0]}")
        return None

    i_s, i_h, i_w, i_g = find("subject"), find("height"), find("weight"), find("sex", "gender", required=False)
    unit = re.search(r"(?<![a-z])(mm|cm|m)(?![a-z])", header[i_h])
    to_m = {"mm": 0.001, "cm": 0.01, "m": 1.0}.get(unit.group(1)) if unit else None
    out, line_of = {}, {}
    for k, row in enumerate(rows[1:], start=2):
        try:
            h, w, s = float(row[i_h]), float(row[i_w]), float(row[i_s])
        except (ValueError, IndexError):
            raise BadInput(f"{path} line {k}: expected numbers for subject, height and weight, got {row}") from None
        if not (s.is_integer() and s >= 0):
            raise BadInput(f"{path} line {k}: subject {row[i_s].strip()!r} is not a whole number (the S<n> folders "
                           f"are numbered by it)")
        subject = str(int(s))
        if subject in out:
            raise BadInput(f"{path} line {k}: subject {subject} is listed again (first on line {line_of[subject]}); "
                           f"expected one row per subject")
        height_m = h * (to_m if to_m is not None else (0.01 if h > 3 else 1.0))
        check_person(height_m, w, f"{path} line {k}, subject {subject}",
                     f"{row[i_h].strip()} {unit.group(1) if unit else '(unit not named: above 3 read as cm)'}")
        g = row[i_g].strip().lower()[:1] if i_g is not None and i_g < len(row) else ""
        out[subject] = {"height_m": height_m, "weight_kg": w, "gender": g if g in ("f", "m") else ""}
        line_of[subject] = k
    return out


def _subject_folders(root: Path) -> list[tuple[str, Path]]:
    """(subject number as str, folder) of every ``S<n>`` folder; BadInput when two folders (``S1``
    and ``S01``) name the same subject, whose images would be counted twice."""
    found = sorted(((str(int(p.name[1:])), p) for p in root.glob("S*") if p.is_dir() and p.name[1:].isdigit()),
                   key=lambda t: (int(t[0]), t[1].name))
    for (a, pa), (b, pb) in zip(found, found[1:]):
        if a == b:
            raise BadInput(f"{root}: folders {pa.name} and {pb.name} are both subject {a}; keep one (its images "
                           f"would be read twice)")
    return found


def _check_readings(path: Path, line: int, tokens: list[str], values: np.ndarray) -> None:
    """BadInput naming the file, the line and the reading when one of a line's readings is NaN,
    infinite, too large for the float32 images are kept in, or negative (a mat reads no pressure
    below 0)."""
    bad = ~np.isfinite(values) | (np.abs(values) > FLOAT32_MAX)
    if bad.any():
        j = int(np.argmax(bad))
        why = "not a finite number" if not np.isfinite(values[j]) else "out of range (too large for float32)"
        raise BadInput(f"{path} line {line}: reading {j + 1} is {tokens[j]!r}, {why}; expected finite readings "
                       f"({int(bad.sum())} such on this line)")
    negative = values < 0
    if negative.any():
        j = int(np.argmax(negative))
        raise BadInput(f"{path} line {line}: reading {j + 1} is {tokens[j]!r}, negative; a pressure mat's readings "
                       f"are >= 0 ({int(negative.sum())} such on this line)")


def read_frame_lines(path: str | Path, shape: tuple[int, int]) -> np.ndarray:
    """All frames (F, rows, cols) float32 of a text recording holding one frame a line (``rows * cols``
    readings separated by tabs or spaces, row-major; blank lines skipped), as stored: PMD
    experiment I's layout. The file is read a line at a time (a night of frames is not held as
    text), and the frames are kept in float32, the precision images are kept in."""
    path = Path(path)
    rows, cols = shape
    try:
        with path.open(encoding="utf-8") as fh:  # first the frames' count, so they are stored once
            count = sum(1 for line in fh if line.strip())
        frames = np.empty((count, rows, cols), dtype=np.float32)
        f = 0
        with path.open(encoding="utf-8") as fh:
            for k, line in enumerate(fh, start=1):
                tokens = line.split()
                if not tokens:
                    continue
                try:
                    values = np.array(tokens, dtype=np.float64)
                except ValueError:
                    raise BadInput(f"{path} line {k}: not all readings are numbers") from None
                _check_readings(path, k, tokens, values)
                if values.size != rows * cols:
                    raise BadInput(f"{path} line {k} has {values.size} readings; expected {rows * cols} (one {rows} x "
                                   f"{cols} frame)")
                frames[f] = values.reshape(shape)
                f += 1
    except (OSError, UnicodeError) as exc:
        raise BadInput(f"{path}: cannot read as utf-8 text ({exc})") from None
    if not count:
        raise BadInput(f"{path} holds no frames")
    return frames


def read_pmd_i_file(path: str | Path) -> np.ndarray:
    """All frames (F, 64, 32) of one experiment-I file, as stored."""
    return read_frame_lines(path, PMD_I_SHAPE)


def read_pmd_i(root: str | Path, frames: str = "one") -> RealImages:
    """PMD experiment I: every ``S<n>/<posture>.txt`` with a subject in ``subject-info-i.csv``.

    frames: 'one' the median of each file's valid frames, 'all' each valid frame. Files without a
    valid frame are left out."""
    root = Path(root)
    info = read_subject_info(root / "subject-info-i.csv")
    records = []
    for subject, folder in _subject_folders(root):
        if subject not in info:
            raise BadInput(f"{folder}: subject {subject} is not in {root / 'subject-info-i.csv'}")
        for path in sorted(folder.glob("*.txt"), key=lambda p: (len(p.stem), p.stem)):
            if not path.stem.isdigit() or int(path.stem) not in PMD_I_POSTURES:
                raise BadInput(f"{path}: expected a posture number 1-17 as the file name")
            posture, detail = PMD_I_POSTURES[int(path.stem)]
            stack = read_pmd_i_file(path)
            ok = valid_frames(stack)
            if not ok.any():
                continue
            if frames == "one":
                chosen = [(-1, combine_frames(stack))]
            else:
                chosen = [(int(i), stack[i]) for i in np.nonzero(ok)[0]]
            for idx, img in chosen:
                records.append(dict(image=img, posture=posture, detail=detail, subject=subject, source=str(path),
                                    frame=idx, **info[subject]))
    if not records:
        raise BadInput(f"{root}: no S<n>/<posture>.txt files with a recorded body")
    return make_real(records, get_mat("fsa_softflex_2048"), "raw", "pmd-i")


_PMD_II_NAME = re.compile(r"^Matrix_(Sponge|Air)_([A-Za-z]+)(\d+)$")


def read_image_lines(path: str | Path, shape: tuple[int, int]) -> np.ndarray:
    """One image (rows, cols) from a text file of ``rows`` lines of ``cols`` space-separated readings
    (blank lines skipped), as stored: PMD experiment II's layout."""
    path = Path(path)
    lines = [(k, ln.split()) for k, ln in enumerate(_read_text(path).splitlines(), start=1) if ln.strip()]
    if len(lines) != shape[0] or any(len(r) != shape[1] for _, r in lines):
        raise BadInput(f"{path}: expected {shape[0]} lines of {shape[1]} space-separated readings, got "
                       f"{len(lines)} lines of {sorted({len(r) for _, r in lines})} values")
    image = np.empty(shape)
    for i, (k, tokens) in enumerate(lines):
        try:
            image[i] = np.array(tokens, dtype=np.float64)
        except ValueError:
            raise BadInput(f"{path} line {k}: not all readings are numbers") from None
        _check_readings(path, k, tokens, image[i])
    return image


def read_pmd_ii_file(path: str | Path) -> np.ndarray:
    """One experiment-II image (64, 27) as stored (feet at row 0)."""
    return read_image_lines(path, PMD_II_SHAPE)


def pmd_ii_posture(letter: str, number: int) -> tuple[str, str] | None:
    """(posture label, description) of an experiment-II posture code such as ``E3`` (module
    docstring); None for a letter the dataset does not use."""
    letter = letter.upper()
    if (letter, number) == PMD_II_INCLINED:
        return "inclined", "supine, head of the bed raised"
    return PMD_II_LETTERS.get(letter)


def read_pmd_ii(root: str | Path) -> RealImages:
    """PMD experiment II: every ``S<n>/{Sponge,Air}_Mat/Matrix_*.txt``, flipped to the head at row 0."""
    root = Path(root)
    info = read_subject_info(root / "subject-info-ii.csv", encoding="utf-16")
    records, unknown = [], {}
    for subject, folder in _subject_folders(root):
        if subject not in info:
            raise BadInput(f"{folder}: subject {subject} is not in {root / 'subject-info-ii.csv'}")
        for mattress in ("Sponge", "Air"):
            for path in sorted((folder / f"{mattress}_Mat").glob("Matrix_*.txt")):
                m = _PMD_II_NAME.match(path.stem)
                if m is None or m.group(1) != mattress:
                    raise BadInput(f"{path}: expected a name Matrix_{mattress}_<letter><number>.txt")
                img = orient(read_pmd_ii_file(path), head_row0=False)
                code = f"{m.group(2).upper()}{int(m.group(3))}"
                known = pmd_ii_posture(m.group(2), int(m.group(3)))
                if known is None:
                    unknown[m.group(2).upper()] = unknown.get(m.group(2).upper(), 0) + 1
                posture, what = known or ("", "posture letter not in the dataset's description")
                records.append(dict(image=img, posture=posture, detail=f"{mattress.lower()} mattress, {code}: {what}",
                                    subject=subject, source=str(path), frame=-1, **info[subject]))
    if not records:
        raise BadInput(f"{root}: no S<n>/{{Sponge,Air}}_Mat/Matrix_*.txt files")
    if unknown:
        letters = ", ".join(f"{k} ({n})" for k, n in sorted(unknown.items()))
        warnings.warn(f"{root}: {sum(unknown.values())} image(s) have a posture letter the PMD experiment-II "
                      f"description does not use ({letters}; known: B-G); they are kept but not scored for posture",
                      stacklevel=2)
    return make_real(records, get_mat("boditrak_bt3510"), "raw", "pmd-ii")
