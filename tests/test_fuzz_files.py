"""Fuzzing what users feed the tool: CSV and MATLAB logs, model files. No traceback, no silent success.

Every call on a damaged, truncated or hand-edited file either returns a valid result (an IOData
whose values are finite and whose lengths agree; a model that runs on its training data) or raises
one of the documented exceptions, exactly ``ValueError``, ``KeyError``, ``TypeError`` or
``FileNotFoundError`` (not a subclass such as ``UnicodeDecodeError`` or pandas' ``ParserError``),
with a one-line message that names the file. Found by these tests and fixed in the readers:

- ``IOData.from_csv``: non-UTF-8 bytes raised ``UnicodeDecodeError``; rows with more fields than
  the header or an unclosed quote raised pandas' ``ParserError``; a file of blank lines raised
  ``EmptyDataError``; a folder raised ``IsADirectoryError``; a headerless file was reported as a
  repeated column name ``'0.0'``; messages did not name the file; an empty cell was reported as
  the value ``nan``.
- ``IOData.from_mat``: a damaged file raised scipy's own errors (``MatReadError``, ``OSError``,
  ``TypeError`` without the file's name); a matrix was flattened into one long channel, complex
  values lost their imaginary part, variables of unequal lengths raised pandas' error, a v7.3
  (HDF5) file raised ``NotImplementedError``.
- ``load_softneck_log``: a byte-order mark made the first time stamp "not a number".
- ``load_model``: a damaged deflate stream raised ``zlib.error``, an unsupported zip feature
  ``NotImplementedError``, an "encrypted" member ``RuntimeError``; a header without ``"class"``
  raised ``KeyError``; a ``"version"`` that is a list, NaN or infinite raised ``TypeError``,
  ``ValueError`` without the path, or ``OverflowError``; a huge integer in the lags raised
  ``OverflowError``; channel names edited in the header loaded a model whose compiled free run
  read outside its input array, or that refused its own training data.
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

import neckid
from neckid.datasets import load_softneck_log
from neckid.models.base import DivergenceError

#: The exception types a reader may raise; exactly these, not subclasses of them.
ALLOWED = (ValueError, KeyError, TypeError, FileNotFoundError)

FUZZ = settings(
    max_examples=300,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)


def assert_clear_refusal(error: BaseException, path: Path) -> None:
    """The exception is an allowed type and its message is one line naming the file."""
    assert type(error) in ALLOWED, f"{type(error).__name__} escaped: {error}"
    event(f"refused: {type(error).__name__}")
    message = error.args[0] if isinstance(error, KeyError) else str(error)
    assert isinstance(message, str) and message.strip(), "empty message"
    assert "\n" not in message, f"message on several lines: {message!r}"
    assert "Traceback" not in message
    assert path.name in message, f"the message does not name {path.name}: {message}"


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("fuzz")


# ====================================================================================== CSV logs
CELLS = [
    "abc",
    "",
    " ",
    "nan",
    "NaN",
    "inf",
    "-inf",
    "1e400",
    "0x1F",
    "1,5",
    '"',
    "\x00",
    "é",
    "１",  # a full-width digit
    "True",
    "1.0.0",
]


def csv_text(n_rows: int, seed: int) -> str:
    rng = np.random.default_rng(seed)
    rows = [f"{0.02 * k:.2f},{rng.normal():.4f},{rng.normal():.4f}" for k in range(n_rows)]
    return "time,cmd,incl\n" + "\n".join(rows) + "\n"


def softneck_text(n_rows: int, n_columns: int, seed: int) -> str:
    rng = np.random.default_rng(seed)
    rows = []
    for k in range(n_rows):
        values = [f"{20.0 + 0.025 * k:.3f}", *(f"{v:.4f}" for v in rng.normal(size=n_columns - 1))]
        rows.append(", ".join(values))
    return "\n".join(rows) + "\n"


@st.composite
def edited_texts(draw: st.DrawFn, text: str, header: bool) -> bytes:
    """A valid log with one class of damage: cells, header, rows, encoding or separator."""
    lines = text.splitlines(keepends=True)
    first = 1 if header else 0
    kind = draw(
        st.sampled_from(
            ["cell", "truncate", "flip", "rows", "repeat", "bom", "separator", "encoding", "header"]
        )
    )
    if kind == "cell":
        row = draw(st.integers(first, len(lines) - 1))
        cells = lines[row].rstrip("\n").split(",")
        cells[draw(st.integers(0, len(cells) - 1))] = draw(st.sampled_from(CELLS))
        lines[row] = ",".join(cells) + "\n"
    elif kind == "truncate":
        data = text.encode()
        return data[: draw(st.integers(0, len(data)))]
    elif kind == "flip":
        data = bytearray(text.encode())
        for _ in range(draw(st.integers(1, 4))):
            data[draw(st.integers(0, len(data) - 1))] = draw(st.integers(0, 255))
        return bytes(data)
    elif kind == "rows":  # unsorted time stamps, or a single row
        if draw(st.booleans()):
            i, j = (
                draw(st.integers(first, len(lines) - 1)),
                draw(st.integers(first, len(lines) - 1)),
            )
            lines[i], lines[j] = lines[j], lines[i]
        else:
            lines = lines[: first + 1]
    elif kind == "repeat":
        row = draw(st.integers(first, len(lines) - 1))
        lines.insert(row, lines[row])
    elif kind == "bom":
        return b"\xef\xbb\xbf" + text.encode()
    elif kind == "separator":
        return text.replace(",", draw(st.sampled_from([";", "\t", "|", " "]))).encode()
    elif kind == "encoding":
        return text.replace("cmd", "cmé").encode(draw(st.sampled_from(["latin-1", "utf-16"])))
    elif header:  # duplicated, missing or renamed header names
        lines[0] = draw(st.sampled_from(["time,cmd,cmd\n", "", "time,cmd\n", "t,cmd,incl\n"]))
    return "".join(lines).encode()


def csv_files() -> st.SearchStrategy[bytes]:
    valid = st.builds(csv_text, st.integers(1, 12), st.integers(0, 3))
    return st.one_of(
        st.binary(max_size=300),
        valid.flatmap(lambda text: edited_texts(text, header=True)),
    )


def softneck_files() -> st.SearchStrategy[bytes]:
    valid = st.builds(
        softneck_text, st.integers(1, 12), st.sampled_from([3, 6, 7]), st.integers(0, 3)
    )
    return st.one_of(
        st.binary(max_size=300),
        valid.flatmap(lambda text: edited_texts(text, header=False)),
    )


def assert_valid_log(data: neckid.IOData) -> None:
    assert np.isfinite(data.u).all() and np.isfinite(data.y).all()
    assert data.u.shape[0] == data.y.shape[0] == data.n_samples >= 1
    assert np.isfinite(data.ts) and data.ts > 0 and np.isfinite(data.t0)


@FUZZ
@given(content=csv_files())
def test_any_csv_gives_a_log_or_a_clear_error(folder: Path, content: bytes) -> None:
    path = folder / "log.csv"
    path.write_bytes(content)
    try:
        data = neckid.IOData.from_csv(path, ["cmd"], ["incl"], time="time")
    except Exception as error:  # the test: nothing else escapes
        assert_clear_refusal(error, path)
    else:
        event("read")
        assert_valid_log(data)
        assert data.u.shape == data.y.shape == (data.n_samples, 1)


@FUZZ
@given(content=softneck_files())
def test_any_softneck_log_gives_a_log_or_a_clear_error(folder: Path, content: bytes) -> None:
    path = folder / "softneck.csv"
    path.write_bytes(content)
    try:
        data = load_softneck_log(path)
    except Exception as error:  # the test: nothing else escapes
        assert_clear_refusal(error, path)
    else:
        event("read")
        assert_valid_log(data)
        assert data.n_outputs >= 1 and data.n_inputs >= 1


# ================================================================================ MATLAB files
MAT_VALUES = [
    np.arange(20.0),
    np.arange(20.0)[:, None],  # a one-column matrix: a vector
    np.arange(20.0)[None, :],  # a one-row matrix: a vector
    np.ones((20, 3)),
    np.ones((2, 10, 2)),
    np.arange(19.0),
    np.array([], dtype=float),
    np.array(3.5),
    np.arange(20.0) + 1j,
    "text",
    np.array(["a", "b"]),
    np.arange(20, dtype=np.int64) * 2**60,
    np.arange(20, dtype=np.int8),
    np.arange(20) % 2 == 0,
    np.array([{"a": 1.0}], dtype=object),
    np.full(20, np.nan),
    np.r_[np.arange(19.0), np.inf],
    np.arange(20.0) * 0.1,  # a time vector
    np.arange(20.0)[::-1] * 0.1,  # time going back
]


@st.composite
def mat_files(draw: st.DrawFn) -> tuple[bytes | None, dict[str, Any]]:
    """(raw bytes or None, variables): a damaged file, or variables to save with savemat."""
    kind = draw(st.sampled_from(["variables", "variables", "random", "truncate", "flip"]))
    if kind == "random":
        return draw(st.binary(max_size=600)), {}
    variables = {
        name: draw(st.sampled_from(MAT_VALUES))
        for name in ("cmd", "incl", "time", "ts")
        if draw(st.booleans()) or name in ("cmd", "incl")
    }
    if kind == "variables":
        return None, variables
    import io

    from scipy.io import savemat

    buffer = io.BytesIO()
    savemat(buffer, {"cmd": np.arange(20.0), "incl": np.arange(20.0) ** 2, "time": np.arange(20.0)})
    raw = bytearray(buffer.getvalue())
    if kind == "truncate":
        return bytes(raw[: draw(st.integers(0, len(raw) - 1))]), {}
    for _ in range(draw(st.integers(1, 6))):
        raw[draw(st.integers(0, len(raw) - 1))] = draw(st.integers(0, 255))
    return bytes(raw), {}


@FUZZ
@given(content=mat_files(), by=st.sampled_from(["time", "ts", "number"]))
def test_any_mat_file_gives_a_log_or_a_clear_error(
    folder: Path, content: tuple[bytes | None, dict[str, Any]], by: str
) -> None:
    from scipy.io import savemat

    raw, variables = content
    path = folder / "log.mat"
    if raw is None:
        savemat(path, variables)
    else:
        path.write_bytes(raw)
    options: dict[str, Any] = (
        {"time": "time"} if by == "time" else {"ts": "ts" if by == "ts" else 0.1}
    )
    try:
        data = neckid.IOData.from_mat(path, ["cmd"], ["incl"], **options)
    except Exception as error:  # the test: nothing else escapes
        assert_clear_refusal(error, path)
    else:
        event("read")
        assert_valid_log(data)
        assert data.u.shape == data.y.shape == (data.n_samples, 1)


def test_mat_matrix_complex_text_and_lengths_are_refused_by_name(folder: Path) -> None:
    from scipy.io import savemat

    path = folder / "named.mat"
    for value, match in (
        (np.ones((20, 3)), r"named\.mat: variable 'incl' is a 20x3 matrix"),
        (np.arange(20.0) + 1j, r"named\.mat: variable 'incl' holds complex numbers"),
        ("text", r"named\.mat: variable 'incl' holds text"),
        (np.arange(19.0), r"named\.mat: the variables read have unequal lengths"),
    ):
        savemat(path, {"cmd": np.arange(20.0), "incl": value})
        with pytest.raises(ValueError, match=match):
            neckid.IOData.from_mat(path, ["cmd"], ["incl"], ts=0.1)


# =================================================================================== model files
class ModelFixture:
    """A training log and the files of two fitted models, with their arrays and header."""

    def __init__(self, folder: Path) -> None:
        rng = np.random.default_rng(7)
        u = rng.normal(size=200)
        y = np.zeros(200)
        for k in range(1, 200):
            y[k] = 0.8 * y[k - 1] + 0.5 * u[k - 1] + 0.01 * rng.normal()
        self.data = neckid.IOData(u=u, y=y, ts=0.025, input_names=["cmd"], output_names=["incl"])
        lags = neckid.Lags.arx(1, 1)
        self.paths = {
            "arx": neckid.LinearARX(lags).fit(self.data).save(folder / "arx.npz"),
            "sm": neckid.SetMembership(lags).fit(self.data).save(folder / "sm.npz"),
        }
        self.arrays: dict[str, dict[str, np.ndarray]] = {}
        self.headers: dict[str, dict[str, Any]] = {}
        for name, path in self.paths.items():
            with np.load(path, allow_pickle=False) as archive:
                arrays = {k: archive[k] for k in archive.files}
            self.headers[name] = json.loads(str(arrays.pop("__neckid__")))
            self.arrays[name] = arrays


@pytest.fixture(scope="module")
def models(folder: Path) -> ModelFixture:
    return ModelFixture(folder)


def write_npz(path: Path, arrays: dict[str, Any], header: Any) -> None:
    payload = dict(arrays)
    payload["__neckid__"] = np.array(json.dumps(header))
    with path.open("wb") as handle:
        np.savez(handle, **payload)


JSON_VALUES = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(-3, 3)
    | st.sampled_from([10**30, -(10**30), 1.5, -0.5, float("nan"), float("inf"), 1e308])
    | st.sampled_from(["", "abc", "1", "LinearARX", "SetMembership", "cmd", "incl"]),
    lambda children: (
        st.lists(children, max_size=3)
        | st.dictionaries(st.sampled_from(["a", "class", "version"]), children, max_size=2)
    ),
    max_leaves=4,
)


def _paths(node: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    found = [prefix]
    if isinstance(node, dict):
        for key, value in node.items():
            found += _paths(value, (*prefix, key))
    elif isinstance(node, list):
        for index, value in enumerate(node):
            found += _paths(value, (*prefix, index))
    return found


@st.composite
def edited_headers(draw: st.DrawFn, header: dict[str, Any]) -> Any:
    """The JSON header with one or two nodes replaced, deleted or given a sibling."""
    edited: Any = json.loads(json.dumps(header))
    for _ in range(draw(st.integers(1, 2))):
        path = draw(st.sampled_from(_paths(edited)))
        value = draw(JSON_VALUES)
        if not path:
            return value
        parent = edited
        for key in path[:-1]:
            parent = parent[key]
        action = draw(st.sampled_from(["replace", "delete", "add"]))
        if action == "replace":
            parent[path[-1]] = value
        elif action == "delete":
            del parent[path[-1]]
        elif isinstance(parent, dict):
            parent[draw(st.sampled_from(["extra", "class", "version", "meta"]))] = value
        else:
            parent.append(value)
    return edited


@st.composite
def edited_arrays(draw: st.DrawFn, arrays: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The arrays with one changed: shape, a NaN/inf/negative/huge value, dtype, gone, or extra."""
    edited = dict(arrays)
    name = draw(st.sampled_from(sorted(arrays)))
    value = np.array(arrays[name])
    action = draw(st.sampled_from(["shape", "value", "dtype", "delete", "extra", "scalar"]))
    if action == "shape":
        edited[name] = draw(
            st.sampled_from([value.ravel(), np.zeros((value.shape[0] + 1, 2)), np.zeros(0)])
        )
    elif action == "value":
        value = value.astype(np.float64)  # every array of a fitted model holds a value
        value.flat[draw(st.integers(0, value.size - 1))] = draw(
            st.sampled_from([np.nan, np.inf, -1.0, 0.0, -1e-300, 1e308])
        )
        edited[name] = value
    elif action == "dtype":
        edited[name] = draw(
            st.sampled_from([value.astype(np.int8), value.astype(str), value.astype(np.complex128)])
        )
    elif action == "delete":
        del edited[name]
    elif action == "extra":
        edited[draw(st.sampled_from(["extra", "coef_0", "linear__coef"]))] = np.ones(3)
    else:
        edited[name] = np.array(3.0)
    return edited


@st.composite
def model_files(
    draw: st.DrawFn, models: ModelFixture
) -> tuple[str, bytes | None, dict[str, Any], Any]:
    """(model name, raw bytes or None, arrays, header): what to write to a model file."""
    name = draw(st.sampled_from(sorted(models.paths)))
    arrays, header = models.arrays[name], models.headers[name]
    raw = models.paths[name].read_bytes()
    kind = draw(st.sampled_from(["random", "truncate", "flip", "header", "arrays"]))
    if kind == "random":
        return name, draw(st.binary(max_size=400)), {}, None
    if kind == "truncate":
        return name, raw[: draw(st.integers(0, len(raw) - 1))], {}, None
    if kind == "flip":
        data = bytearray(raw)
        for _ in range(draw(st.integers(1, 4))):
            data[draw(st.integers(0, len(data) - 1))] = draw(st.integers(0, 255))
        return name, bytes(data), {}, None
    if kind == "header":
        return name, None, arrays, draw(edited_headers(header))
    return name, None, draw(edited_arrays(arrays)), header


def runs_on(model: Any, data: neckid.IOData) -> neckid.IOData:
    """The training log with the model's channel names and sampling period (a header edit may
    rename them: the model is then valid, for a log of that name)."""
    n_inputs, n_outputs = len(model.input_names_), len(model.output_names_)
    return neckid.IOData(
        u=np.tile(data.u[:, :1], (1, n_inputs)),
        y=np.tile(data.y[:, :1], (1, n_outputs)),
        ts=model.ts_ if np.isfinite(model.ts_) else data.ts,
        input_names=model.input_names_,
        output_names=model.output_names_,
    )


@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # overflow in a model with huge values
@pytest.mark.filterwarnings("ignore::neckid.models.base.ExtrapolationWarning")
@FUZZ
@given(st.data())
def test_any_model_file_loads_a_working_model_or_a_clear_error(
    folder: Path, models: ModelFixture, data: st.DataObject
) -> None:
    name, raw, arrays, header = data.draw(model_files(models))
    path = folder / f"edited_{name}.npz"
    if raw is None:
        write_npz(path, arrays, header)
    else:
        path.write_bytes(raw)
    try:
        model = neckid.load_model(path)
    except Exception as error:  # the test: nothing else escapes
        assert type(error) in (ValueError, FileNotFoundError), f"{type(error).__name__}: {error}"
        assert_clear_refusal(error, path)
        assert str(path) in str(error)
        return
    event("loaded")
    try:
        result = model.simulate(runs_on(model, models.data))
    except DivergenceError:
        # Finite but huge learned values make an unstable model: it loads (nothing in the file
        # is inconsistent) and its free run is refused with the documented error.
        assert raw is None
        return
    assert np.isfinite(result.y).all()


def test_object_arrays_are_never_unpickled(folder: Path, models: ModelFixture) -> None:
    marker = folder / "unpickled"

    class Payload:
        def __reduce__(self) -> tuple[Any, tuple[str]]:
            return (os.makedirs, (str(marker),))

    path = folder / "pickled.npz"
    arrays = dict(models.arrays["arx"])
    arrays["coef"] = np.array([Payload()], dtype=object)
    write_npz(path, arrays, models.headers["arx"])
    with pytest.raises(
        ValueError, match=re.escape(f"{path} is not a neckid model file") + r".*pickle"
    ):
        neckid.load_model(path)
    assert not marker.exists()


def _header(models: ModelFixture, name: str, **changes: Any) -> dict[str, Any]:
    header = json.loads(json.dumps(models.headers[name]))
    for dotted, value in changes.items():
        *parents, last = dotted.split("__")
        node = header
        for key in parents:
            node = node[key]
        if value is _DELETE:
            del node[last]
        else:
            node[last] = value
    return header


_DELETE = object()

HEADER_EDITS = [
    ("arx", "a list", lambda m: [1, 2], r"header must be a JSON object; got a JSON list"),
    ("arx", "a number", lambda m: 3, r"header must be a JSON object; got a JSON int"),
    (
        "arx",
        "no class",
        lambda m: _header(m, "arx", **{"class": _DELETE}),
        r"must name the model class in 'class'; got None",
    ),
    (
        "arx",
        "unknown class",
        lambda m: _header(m, "arx", **{"class": "Pickle"}),
        r"holds a 'Pickle', which this neckid cannot load",
    ),
    (
        "arx",
        "version string",
        lambda m: _header(m, "arx", version="1"),
        r"version must be a whole number >= 1; got '1'",
    ),
    (
        "arx",
        "version list",
        lambda m: _header(m, "arx", version=[1]),
        r"version must be a whole number >= 1; got \[1\]",
    ),
    (
        "arx",
        "version NaN",
        lambda m: _header(m, "arx", version=float("nan")),
        r"version must be a whole number >= 1; got nan",
    ),
    (
        "arx",
        "version huge",
        lambda m: _header(m, "arx", version=10**30),
        r"has model-file version 1000000000000000000000000000000, newer",
    ),
    (
        "arx",
        "meta a list",
        lambda m: _header(m, "arx", meta=[]),
        r"'meta' .* must be a JSON object; got a JSON list",
    ),
    (
        "arx",
        "unknown param",
        lambda m: _header(m, "arx", meta__params__speed=3),
        r"invalid LinearARX file: .*speed",
    ),
    (
        "arx",
        "param a string",
        lambda m: _header(m, "arx", meta__params__ridge="abc"),
        r"invalid LinearARX file: .*ridge",
    ),
    (
        "arx",
        "ts a string",
        lambda m: _header(m, "arx", meta__ts="fast"),
        r"invalid LinearARX file: could not convert string to float",
    ),
    (
        "arx",
        "ts negative",
        lambda m: _header(m, "arx", meta__ts=-0.025),
        r"invalid LinearARX file: ts must be a positive number",
    ),
    (
        "arx",
        "huge lag",
        lambda m: _header(m, "arx", meta__lags__lag=[1, 10**30]),
        r"invalid LinearARX file: .*too large",
    ),
    (
        "arx",
        "input renamed",
        lambda m: _header(m, "arx", meta__input_names=["other"]),
        r"regressor was built for channels \['cmd'\] -> \['incl'\], but the model has \['other'\]",
    ),
    (
        "sm",
        "no input",
        lambda m: _header(m, "sm", meta__input_names=[]),
        r"but the model has \[\] -> \['incl'\]",
    ),
    (
        "sm",
        "channel out of range",
        lambda m: _header(m, "sm", meta__lags__channel=[0, -1]),
        r"regressor term 1 \('cmd\(t-1\)'\) has source 1, channel -1",
    ),
    (
        "sm",
        "lag beyond max_lag",
        lambda m: _header(m, "sm", meta__lags__lag=[1, 4]),
        r"regressor term 1 .* lag 4: .*max_lag=1",
    ),
    (
        "sm",
        "max_lag huge",
        lambda m: _header(m, "sm", meta__lags__max_lag=10**9),
        r"invalid SetMembership file: max_lag",
    ),
    (
        "sm",
        "names not strings",
        lambda m: _header(m, "sm", meta__output_names=[1], meta__lags__output_names=[1]),
        r"output_names must be strings; got \[1\]",
    ),
]


@pytest.mark.parametrize(
    ("name", "case", "edit", "match"), HEADER_EDITS, ids=[c[1] for c in HEADER_EDITS]
)
def test_edited_headers_are_refused_with_the_reason(
    folder: Path, models: ModelFixture, name: str, case: str, edit: Any, match: str
) -> None:
    path = folder / "header.npz"
    write_npz(path, models.arrays[name], edit(models))
    with pytest.raises(ValueError, match=match) as error:
        neckid.load_model(path)
    assert str(error.value).startswith(str(path))


ARRAY_EDITS = [
    ("arx", "coef", np.zeros((3, 1)), r"coef must have shape \(2, 1\); got \(3, 1\)"),
    ("arx", "coef", np.array([[np.nan], [1.0]]), r"coef holds a non-finite value"),
    ("sm", "gamma", np.array([-1.0]), r"gamma must be > 0"),
    ("sm", "x_train", np.zeros((5, 2)), r"x_train must have shape \(199, 2\)"),
    (
        "sm",
        "weights",
        np.array(["a", "b"]),
        r"invalid SetMembership file: could not convert string to float",
    ),
    ("sm", "gamma", None, r"this SetMembership file has no 'gamma' entry"),
]


@pytest.mark.parametrize(("name", "key", "value", "match"), ARRAY_EDITS)
def test_edited_arrays_are_refused_with_the_reason(
    folder: Path, models: ModelFixture, name: str, key: str, value: Any, match: str
) -> None:
    path = folder / "arrays.npz"
    arrays = dict(models.arrays[name])
    if value is None:
        del arrays[key]
    else:
        arrays[key] = value
    write_npz(path, arrays, models.headers[name])
    with pytest.raises(ValueError, match=match) as error:
        neckid.load_model(path)
    assert str(error.value).startswith(str(path))


def test_an_extra_array_is_ignored(folder: Path, models: ModelFixture) -> None:
    path = folder / "extra.npz"
    write_npz(path, {**models.arrays["sm"], "notes": np.ones(3)}, models.headers["sm"])
    loaded = neckid.load_model(path)
    original = neckid.load_model(models.paths["sm"])
    np.testing.assert_array_equal(loaded.simulate(models.data).y, original.simulate(models.data).y)


def test_a_crash_of_the_compiled_mat_reader_is_one_clear_error(monkeypatch, tmp_path) -> None:
    """SciPy's and HDF5's readers can crash on a damaged file; the child process takes it."""
    import os
    import signal

    from neckid.data import readers

    def crash(path, names):
        os.kill(os.getpid(), signal.SIGSEGV)

    monkeypatch.setattr(readers, "_mat_variables_here", crash)
    path = tmp_path / "damaged.mat"
    path.write_bytes(b"MATLAB 5.0 MAT-file" + bytes(200))
    with pytest.raises(ValueError, match=r"damaged.mat .*the MATLAB reader crashed on it"):
        readers._mat_variables(path, ["u"])
