"""Model files that are damaged, crafted or from a newer neckid: refused by name, before allocating.

What :mod:`neckid.models.io_checks` refuses, one test per check, each with the case that proves
it: a declared shape that the entry's bytes do not fill (``10**12`` values in 16 bytes), a zip
bomb (1.6 MB on disk, 1.6 GB of zeros once read), arrays larger than the memory there is, dtypes
no model writes (complex, objects, records, dates, text, bytes), booleans or integers where real
numbers belong (and the reverse), header numbers no fitted model has (``ts`` NaN or infinite,
ranges reversed or NaN, ``n_samples`` negative), a header nested too deeply, a format version
from a newer neckid, entries that are not ``.npy`` arrays. Every message is one line that
starts with the file's path and names the entry or header key.
"""

from __future__ import annotations

import io
import json
import struct
import time
import tracemalloc
import warnings
import zlib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from typer.testing import CliRunner

import neckid
from neckid import IOData, Lags
from neckid.cli import app
from neckid.models.io import FORMAT_VERSION

runner = CliRunner()


def _data() -> IOData:
    rng = np.random.default_rng(3)
    u = np.repeat(rng.uniform(-1, 1, 30), 10)
    y = np.zeros(300)
    for k in range(1, 300):
        y[k] = 0.8 * y[k - 1] + 0.4 * np.tanh(u[k - 1]) + 0.01 * rng.normal()
    return IOData(u, y, ts=0.02, input_names=["command"], output_names=["inclination"])


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A model file of four methods: real arrays (arx), integers (poly), booleans (sm), parts
    (sm-parallel: ``linear.ts``)."""
    folder = tmp_path_factory.mktemp("models")
    data = _data()
    paths = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name in ("arx", "poly", "sm", "sm-parallel"):
            model = neckid.methods()[name].make(Lags.arx(1, 1), quick=True).fit(data)
            paths[name] = model.save(folder / f"{name}.npz")
    data.to_csv(folder / "log.csv")
    return paths


def _content(path: Path) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    with np.load(path, allow_pickle=False) as archive:
        arrays = {k: archive[k] for k in archive.files}
    return arrays, json.loads(str(arrays.pop("__neckid__")))


def _write(path: Path, arrays: dict[str, Any], header: Any, raw_header: str | None = None) -> Path:
    payload = dict(arrays)
    payload["__neckid__"] = np.array(json.dumps(header) if raw_header is None else raw_header)
    with path.open("wb") as handle:
        np.savez_compressed(handle, **payload)
    return path


def npy_bytes(array: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, array, allow_pickle=False)
    return buffer.getvalue()


def npy_header(shape: tuple[int, ...], descr: str = "<f8") -> bytes:
    buffer = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        buffer, {"descr": descr, "fortran_order": False, "shape": shape}
    )
    return buffer.getvalue()


def deflate(data: bytes) -> bytes:
    compressor = zlib.compressobj(9, zlib.DEFLATED, -15)
    return compressor.compress(data) + compressor.flush()


def raw_zip(path: Path, entries: list[tuple[str, bytes, int, int]]) -> Path:
    """A zip of deflated entries ``(name, deflated bytes, size once inflated, crc32)`` as given:
    what an entry declares is written as is, true or not."""
    body, directory = bytearray(), bytearray()
    for name, data, size, crc in entries:
        encoded, offset = name.encode(), len(body)
        body += struct.pack("<IHHHHHIIIHH", 0x04034B50, 20, 0, 8, 0, 0x21, crc, len(data), size,
                            len(encoded), 0) + encoded + data  # fmt: skip
        directory += struct.pack("<IHHHHHHIIIHHHHHII", 0x02014B50, 20, 20, 0, 8, 0, 0x21, crc,
                                 len(data), size, len(encoded), 0, 0, 0, 0, 0, offset) + encoded  # fmt: skip
    end = struct.pack("<IHHHHIIH", 0x06054B50, 0, 0, len(entries), len(entries), len(directory),
                      len(body), 0)  # fmt: skip
    path.write_bytes(bytes(body + directory + end))
    return path


def entries_of(path: Path, replace: dict[str, tuple[bytes, int, int]]) -> list:
    """The entries of a model file, deflated, with some replaced by ``(deflated, size, crc)``."""
    arrays, header = _content(path)
    arrays["__neckid__"] = np.array(json.dumps(header))
    entries = []
    for name, array in arrays.items():
        raw = npy_bytes(array)
        data, size, crc = replace.get(name, (deflate(raw), len(raw), zlib.crc32(raw)))
        entries.append((f"{name}.npy", data, size, crc))
    return entries


def _refused(path: Path, match: str) -> str:
    with pytest.raises(ValueError, match=match) as error:
        neckid.load_model(path)
    message = str(error.value)
    assert message.startswith(str(path)) and "\n" not in message, message
    return message


# ------------------------------------------------------------------------ sizes and shapes
@pytest.mark.parametrize(
    ("shape", "descr", "match"),
    [
        (
            (10**12,),
            "<f8",
            r"declares shape \(1000000000000,\) of float64 \(7\.3 TB\) but holds 16 B",
        ),
        (
            (3, 10**11),
            "<f8",
            r"declares shape \(3, 100000000000\) of float64 \(2\.2 TB\) but holds 16 B",
        ),
        ((4,), "<f8", r"declares shape \(4,\) of float64 \(32 B\) but holds 16 B"),
        ((2,), "<f4", r"declares shape \(2,\) of float32 \(8 B\) but holds 16 B"),
        ((0,), "<f8", r"declares shape \(0,\) of float64 \(0 B\) but holds 16 B"),
    ],
)
def test_a_declared_shape_its_bytes_do_not_fill_is_refused_unread(
    files: dict[str, Path], tmp_path: Path, shape: tuple[int, ...], descr: str, match: str
) -> None:
    path = declared_shape(tmp_path / "shape.npz", files["arx"], shape, descr)
    _refused(path, rf"is damaged: entry 'coef' {match} of values; refused before reading it")


def zip_bomb(path: Path, model: Path) -> Path:
    """The model file ``model`` whose ``coef`` is 1.6 GB of zeros deflated to 1.6 MB, at ``path``.

    Built in a fifth of a second: a fully flushed deflate block of 16 MiB of zeros, repeated
    (the CRC is never checked: the file is refused before the entry is read).
    """
    chunk, repeats = bytes(16 * 2**20), 100
    head = npy_header((repeats * len(chunk) // 8,))
    compressor = zlib.compressobj(9, zlib.DEFLATED, -15)
    first = compressor.compress(head) + compressor.flush(zlib.Z_FULL_FLUSH)
    piece = compressor.compress(chunk) + compressor.flush(zlib.Z_FULL_FLUSH)  # the same each time
    stream = first + piece * repeats + compressor.flush()
    size = len(head) + repeats * len(chunk)
    return raw_zip(path, entries_of(model, {"coef": (stream, size, 0)}))


def declared_shape(path: Path, model: Path, shape: tuple[int, ...], descr: str = "<f8") -> Path:
    """The model file ``model`` whose ``coef`` entry declares ``shape`` of ``descr`` in its
    ``.npy`` header but holds the 16 bytes of two float64 values, at ``path``."""
    raw = npy_header(shape, descr) + np.array([0.8, 0.4]).tobytes()
    return raw_zip(path, entries_of(model, {"coef": (deflate(raw), len(raw), zlib.crc32(raw))}))


def test_a_zip_bomb_is_refused_before_it_inflates(files: dict[str, Path], tmp_path: Path) -> None:
    """1.6 MB on disk, 1.6 GB of zeros once read: refused in well under a second, under 64 MB."""
    path = zip_bomb(tmp_path / "bomb.npz", files["arx"])
    assert path.stat().st_size < 2e6
    tracemalloc.start()
    start = time.perf_counter()
    try:
        message = _refused(path, r"is damaged: its 1\.6 MB inflate to 1\.6 GB of arrays")
    finally:
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    assert "entry 'coef' alone 1.6 GB" in message and "zip bomb" in message
    assert peak < 64 * 2**20, f"{peak / 2**20:.0f} MB allocated before the refusal"
    assert time.perf_counter() - start < 5.0


def test_arrays_larger_than_the_memory_available_are_refused(
    files: dict[str, Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    import neckid.utils.memory

    monkeypatch.setattr(neckid.utils.memory, "available_bytes", lambda: 2000)
    _refused(
        files["sm"],
        r": reading its arrays \(entry 'x_train' alone .*\) needs about .* of memory, and this"
        r" machine has 2\.0 KB available: refused before reading them",
    )


# ------------------------------------------------------------------------------- dtypes
@pytest.mark.parametrize(
    ("value", "match"),
    [
        (np.array([[0.8], [0.4]]) + 1j, r"entry 'coef' holds complex numbers, dtype complex128"),
        (np.array([[0.8], [0.4]]).astype(str), r"entry 'coef' holds text, dtype <U32"),
        (np.array([[b"0.8"], [b"0.4"]]), r"entry 'coef' holds bytes, dtype \|S3"),
        (np.zeros((2, 1), dtype=[("a", "<f8")]), r"entry 'coef' holds records"),
        (np.zeros((2, 1), dtype="datetime64[s]"), r"entry 'coef' holds dates"),
        (np.zeros((2, 1), dtype="timedelta64[s]"), r"entry 'coef' holds durations"),
    ],
    ids=["complex", "text", "bytes", "records", "dates", "durations"],
)
def test_dtypes_no_model_writes_are_refused_by_entry(
    files: dict[str, Path], tmp_path: Path, value: np.ndarray, match: str
) -> None:
    arrays, header = _content(files["arx"])
    path = _write(tmp_path / "dtype.npz", {**arrays, "coef": value}, header)
    _refused(path, rf"is not a neckid model file \({match}.*a model file holds numbers; refused")


def test_python_objects_are_refused_without_unpickling(
    files: dict[str, Path], tmp_path: Path
) -> None:
    arrays, header = _content(files["arx"])
    path = tmp_path / "objects.npz"
    payload = {**arrays, "coef": np.array([None, 1.0], dtype=object)}
    payload["__neckid__"] = np.array(json.dumps(header))
    np.savez(path, **payload)  # allow_pickle is the default when writing
    _refused(path, r"entry 'coef' holds Python objects, dtype object, which would need pickle")


@pytest.mark.parametrize(
    ("method", "entry", "value", "match"),
    [
        ("arx", "coef", np.array([[True], [False]]), r"entry 'coef' holds booleans \(dtype bool\);"
         r" a LinearARX file holds real numbers there \(dtype float64\)"),
        ("arx", "coef", np.array([[1], [0]]), r"entry 'coef' holds integers \(dtype int64\); a"
         r" LinearARX file holds real numbers there \(dtype float64\)"),
        ("poly", "powers", None, r"entry 'powers' holds real numbers \(dtype float64\); a"
         r" PolynomialNARX file holds integers there \(dtype int64\)"),
        ("sm", "prior_valid", np.array([2], dtype=np.int8), r"entry 'prior_valid' holds integers"
         r" \(dtype int8\); a SetMembership file holds booleans there \(dtype bool\)"),
    ],
    ids=["bool for real", "int for real", "real for int", "2 for bool"],
)  # fmt: skip
def test_another_kind_of_values_than_the_class_writes_is_refused(
    files: dict[str, Path], tmp_path: Path, method: str, entry: str, value: Any, match: str
) -> None:
    arrays, header = _content(files[method])
    value = arrays[entry].astype(np.float64) if value is None else value
    path = _write(tmp_path / "kind.npz", {**arrays, entry: value}, header)
    _refused(path, match + r": it was edited or damaged")


def test_flags_stored_as_zeros_and_ones_load(files: dict[str, Path], tmp_path: Path) -> None:
    arrays, header = _content(files["sm"])
    flags = arrays["prior_valid"].astype(np.int8)
    path = _write(tmp_path / "flags.npz", {**arrays, "prior_valid": flags}, header)
    loaded = neckid.load_model(path)
    original = neckid.load_model(files["sm"])
    np.testing.assert_array_equal(loaded.simulate(_data()).y, original.simulate(_data()).y)


# ------------------------------------------------------------------------- header numbers
def _edit(header: dict[str, Any], dotted: str, value: Any) -> dict[str, Any]:
    edited = json.loads(json.dumps(header))
    *parents, last = dotted.split(".")
    node = edited
    for key in parents:
        node = node[key]
    node[last] = value
    return edited


NAN, INF = float("nan"), float("inf")

HEADER_NUMBERS = [
    ("arx", "meta.ts", NAN, r"header key 'meta\.ts': ts must be a positive number of seconds; got nan"),
    ("arx", "meta.ts", INF, r"header key 'meta\.ts': ts must be a positive number of seconds; got inf"),
    ("arx", "meta.ts", -INF, r"header key 'meta\.ts': .*; got -inf"),
    ("arx", "meta.ts", 0, r"header key 'meta\.ts': ts must be a positive number of seconds; got 0\.0"),
    ("arx", "meta.ts", True, r"header key 'meta\.ts': ts must be a number of seconds; got True"),
    ("arx", "meta.ts", "0.02", r"header key 'meta\.ts': ts must be a number of seconds; got '0\.02'"),
    ("arx", "meta.ts", 1e307, r"header key 'meta\.ts': ts must be .* at most 1e\+06"),
    ("sm-parallel", "meta.linear.ts", NAN, r"header key 'meta\.linear\.ts': .*; got nan"),
    ("arx", "meta.training_ranges.command", [1.0, -1.0],
     r"header key 'meta\.training_ranges\.command' must be \[low, high\], two finite numbers with"
     r" low <= high; got \[1\.0, -1\.0\]"),
    ("arx", "meta.training_ranges.command", [NAN, 1.0], r"'meta\.training_ranges\.command' .*got \[nan, 1\.0\]"),
    ("arx", "meta.training_ranges.inclination", [0.0, INF], r"'meta\.training_ranges\.inclination' .*got \[0\.0, inf\]"),
    ("arx", "meta.training_ranges.command", [0, 1, 2], r"'meta\.training_ranges\.command' .*got \[0, 1, 2\]"),
    ("arx", "meta.training_ranges.command", ["0", "1"], r"'meta\.training_ranges\.command' .*got \['0', '1'\]"),
    ("arx", "meta.training_ranges", [[0, 1]], r"header key 'meta\.training_ranges' must be an object of \[low, high\] pairs"),
    ("arx", "meta.regressor_ranges.command(t-1)", [2.0, 1.0], r"'meta\.regressor_ranges\.command\(t-1\)' .*got \[2\.0, 1\.0\]"),
    ("arx", "meta.n_samples", -1, r"header key 'meta\.n_samples' must be a whole number >= 0; got -1"),
    ("arx", "meta.n_samples", 1.5, r"header key 'meta\.n_samples' must be a whole number >= 0; got 1\.5"),
    ("arx", "meta.n_samples", True, r"header key 'meta\.n_samples' must be a whole number >= 0; got True"),
]  # fmt: skip


@pytest.mark.parametrize(("method", "key", "value", "match"), HEADER_NUMBERS)
def test_header_numbers_no_fitted_model_has_are_refused_by_key(
    files: dict[str, Path], tmp_path: Path, method: str, key: str, value: Any, match: str
) -> None:
    arrays, header = _content(files[method])
    path = _write(tmp_path / "numbers.npz", arrays, _edit(header, key, value))
    _refused(path, match)


def test_a_newer_format_version_is_refused_naming_both_versions(
    files: dict[str, Path], tmp_path: Path
) -> None:
    arrays, header = _content(files["arx"])
    header = {**header, "version": FORMAT_VERSION + 1, "neckid_version": "9.0.0"}
    path = _write(tmp_path / "newer.npz", arrays, header)
    _refused(
        path,
        rf"has model-file version {FORMAT_VERSION + 1}, written by neckid 9\.0\.0, newer than this"
        rf" neckid reads \(neckid {neckid.__version__} reads versions up to {FORMAT_VERSION}\);"
        " upgrade neckid to load it",
    )


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("[" * 100_000 + "]" * 100_000, r"header is nested too deeply to be a neckid header"),
        ('{"version": ' + "9" * 5000 + "}", r"header is not valid JSON: Exceeds the limit"),
    ],
    ids=["nested", "long integer"],
)
def test_a_header_json_cannot_exhaust_the_reader(
    files: dict[str, Path], tmp_path: Path, text: str, match: str
) -> None:
    arrays, _ = _content(files["arx"])
    _refused(_write(tmp_path / "json.npz", arrays, None, raw_header=text), match)


# ---------------------------------------------------------------------- archive structure
def test_entries_not_npy_arrays_repeated_or_too_many_are_refused(
    files: dict[str, Path], tmp_path: Path
) -> None:
    entries = entries_of(files["arx"], {})
    text = json.dumps(_content(files["arx"])[1]).encode()
    header = ("__neckid__", deflate(text), len(text), zlib.crc32(text))
    plain = raw_zip(tmp_path / "plain.npz", [*entries[:-1], header])
    _refused(plain, r"not a neckid model file \(entry '__neckid__' is not a NumPy \.npy array")
    twice = raw_zip(tmp_path / "twice.npz", [entries[0], *entries])
    _refused(twice, r"is damaged: entry 'coef\.npy' appears twice in the archive")
    single = tmp_path / "single.npz"
    single.write_bytes(npy_bytes(np.ones(3)))
    _refused(single, r"not a neckid model file \(a single \.npy array, not an \.npz archive\)")
    one = entries_of(files["arx"], {})[0][1:]
    many = raw_zip(tmp_path / "many.npz", [(f"a{k}.npy", *one) for k in range(10_001)])
    _refused(many, r"not a neckid model file \(it has 10001 entries; a model has a few dozen")


# ------------------------------------------------------------------------- the command line
@pytest.mark.parametrize("kind", ["shape", "version", "ts", "complex"])
def test_the_command_line_refuses_them_with_exit_status_2(
    files: dict[str, Path], tmp_path: Path, kind: str
) -> None:
    arrays, header = _content(files["arx"])
    path = tmp_path / f"{kind}.npz"
    if kind == "shape":
        declared_shape(path, files["arx"], (10**12,))
    elif kind == "version":
        _write(path, arrays, {**header, "version": FORMAT_VERSION + 1})
    elif kind == "ts":
        _write(path, arrays, _edit(header, "meta.ts", NAN))
    else:
        _write(path, {**arrays, "coef": arrays["coef"] + 1j}, header)
    log = files["arx"].parent / "log.csv"
    for args in (["info", path], ["validate", path, log]):
        result = runner.invoke(app, [str(a) for a in args])
        assert result.exit_code == 2, result.output
        assert "Traceback" not in result.output and f"{kind}.npz" in result.output
