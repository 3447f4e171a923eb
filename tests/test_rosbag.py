"""load_rosbag: ROS 2 bags written with rosbags' own Writer, read back against the known signals."""

from __future__ import annotations

import importlib.metadata
import importlib.util
import inspect
import math
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from neckid.datasets import RosbagChannel, load_rosbag
from neckid.datasets.rosbag import ROSBAGS_MISSING

HAVE_ROSBAGS = importlib.util.find_spec("rosbags") is not None
needs_rosbags = pytest.mark.skipif(
    not HAVE_ROSBAGS,
    reason="rosbags is not installed; it comes with the test extra (pip install -e '.[test]')",
)

START_NS = 1_700_000_000 * 10**9  # the bag's first message: 2023-11-14, an ordinary epoch time
FREQUENCY = 0.5  # Hz, of the sine and cosine signals
CMD_PERIOD = 0.01  # /motor/cmd, std_msgs/msg/Float64 at 100 Hz, receive times only
TILT_PERIOD = 0.02  # /imu/tilt, geometry_msgs/msg/Vector3Stamped at 50 Hz, header stamps
TILT_FIRST = 0.105  # header stamp of the first /imu/tilt message, s after the bag's start
TILT_LATENCY = 0.003  # receive time - header stamp of every /imu/tilt message, s
N_CMD, N_TILT = 200, 90  # /motor/cmd spans 0 to 1.99 s, /imu/tilt 0.105 to 1.885 s

CHANNELS = {
    "velocity_command": ("/motor/cmd", "data", "input", "rad/s"),
    "inclination": ("/imu/tilt", "vector.x", "output", "deg"),
}


def command(t: np.ndarray) -> np.ndarray:
    return np.sin(2 * np.pi * FREQUENCY * t)


def tilt_x(t: np.ndarray) -> np.ndarray:
    return 2.0 * np.cos(2 * np.pi * FREQUENCY * t)


def tilt_y(t: np.ndarray) -> np.ndarray:
    return 3.0 - 0.5 * t  # linear: interpolated exactly


def ns(seconds: float) -> int:
    """Nanoseconds after the bag's start, rounded to the nanosecond."""
    return START_NS + round(seconds * 1e9)


def storages() -> list[str]:
    if not HAVE_ROSBAGS:
        return ["sqlite3"]
    import rosbags.rosbag2

    # Choosing the storage (StoragePlugin) came with rosbags 0.10.x; 0.10.0 writes sqlite3 only.
    return ["sqlite3", "mcap"] if hasattr(rosbags.rosbag2, "StoragePlugin") else ["sqlite3"]


def typestore() -> Any:
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_HUMBLE)


def write_bag(
    path: Path,
    storage: str,
    topics: dict[str, tuple[str, list[tuple[int, object]]]],
    types: Any = None,
) -> Path:
    """Write ``{topic: (msgtype, [(receive_ns, message), ...])}`` as a rosbag2 bag at ``path``."""
    from rosbags import rosbag2

    types = typestore() if types is None else types
    parameters = inspect.signature(rosbag2.Writer).parameters
    options: dict[str, Any] = {"version": 8} if "version" in parameters else {}
    if storage == "mcap":
        options["storage_plugin"] = rosbag2.StoragePlugin.MCAP
    records = []
    with rosbag2.Writer(path, **options) as writer:
        for topic, (msgtype, messages) in topics.items():
            connection = writer.add_connection(topic, msgtype, typestore=types)
            for receive_ns, message in messages:
                raw = bytes(types.serialize_cdr(message, msgtype))
                records.append((receive_ns, topic, connection, raw))
        for receive_ns, _, connection, raw in sorted(records, key=lambda r: (r[0], r[1])):
            writer.write(connection, receive_ns, raw)
    return path


def float64s(times: np.ndarray, values: np.ndarray) -> tuple[str, list[tuple[int, object]]]:
    msg = typestore().types["std_msgs/msg/Float64"]
    return "std_msgs/msg/Float64", [
        (ns(t), msg(data=float(v))) for t, v in zip(times, values, strict=True)
    ]


def stamped(
    stamps: list[int], receive: list[int], x: np.ndarray, y: np.ndarray
) -> tuple[str, list[tuple[int, object]]]:
    types = typestore().types
    header, time = types["std_msgs/msg/Header"], types["builtin_interfaces/msg/Time"]
    vector, message = types["geometry_msgs/msg/Vector3"], types["geometry_msgs/msg/Vector3Stamped"]
    return "geometry_msgs/msg/Vector3Stamped", [
        (
            r,
            message(
                header=header(stamp=time(sec=s // 10**9, nanosec=s % 10**9), frame_id="imu"),
                vector=vector(x=float(a), y=float(b), z=7.0),
            ),
        )
        for s, r, a, b in zip(stamps, receive, x, y, strict=True)
    ]


def joint_states(times: np.ndarray) -> tuple[str, list[tuple[int, object]]]:
    types = typestore().types
    header, time = types["std_msgs/msg/Header"], types["builtin_interfaces/msg/Time"]
    message = types["sensor_msgs/msg/JointState"]
    return "sensor_msgs/msg/JointState", [
        (
            ns(t),
            message(
                header=header(stamp=time(sec=ns(t) // 10**9, nanosec=ns(t) % 10**9), frame_id=""),
                name=["tendon", "motor"],
                position=np.array([t, 10.0 * t]),
                velocity=np.array([], dtype=np.float64),
                effort=np.array([], dtype=np.float64),
            ),
        )
        for t in times
    ]


@pytest.fixture(scope="module", params=storages())
def bag(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A bag with the two signals of the brief plus the topics the error cases need."""
    if not HAVE_ROSBAGS:
        pytest.skip("rosbags is not installed; it comes with the test extra")
    storage = request.param
    cmd_times = CMD_PERIOD * np.arange(N_CMD)
    tilt_times = TILT_FIRST + TILT_PERIOD * np.arange(N_TILT)
    tilt_stamps = [ns(t) for t in tilt_times]
    string = typestore().types["std_msgs/msg/String"]
    backwards = [ns(t) for t in (0.2, 0.3, 0.25, 0.4)]
    gappy = np.concatenate([np.arange(0.0, 0.5, 0.05), np.arange(1.2, 2.0, 0.05)])
    topics = {
        "/motor/cmd": float64s(cmd_times, command(cmd_times)),
        "/imu/tilt": stamped(
            tilt_stamps,
            [s + round(TILT_LATENCY * 1e9) for s in tilt_stamps],
            tilt_x(tilt_times),
            tilt_y(tilt_times),
        ),
        "/joint_states": joint_states(0.04 * np.arange(50)),
        "/status": (
            "std_msgs/msg/String",
            [(ns(0.5), string(data="ok")), (ns(0.6), string(data="ok"))],
        ),
        "/single": float64s(np.array([0.5]), np.array([1.0])),
        "/late": float64s(np.array([5.0, 6.0]), np.array([1.0, 2.0])),
        "/nan": float64s(0.1 * np.arange(5), np.array([0.0, 1.0, 2.0, np.nan, 4.0])),
        "/backwards": stamped(
            backwards, [ns(t) for t in (0.2, 0.3, 0.4, 0.5)], np.ones(4), np.ones(4)
        ),
        # A publisher that never fills header.stamp: every stamp is 0.
        "/unstamped": stamped(
            [0] * 4, [ns(t) for t in (0.2, 0.4, 0.6, 0.8)], np.arange(4.0), np.ones(4)
        ),
        "/gappy": float64s(gappy, gappy),
    }
    path = tmp_path_factory.mktemp(storage) / f"run_{storage}"
    return write_bag(path, storage, topics)


# --- reading the known signals ------------------------------------------------------------------


@needs_rosbags
def test_channels_names_units_and_name(bag: Path) -> None:
    data = load_rosbag(bag, CHANNELS)
    assert list(data.input_names) == ["velocity_command"]
    assert list(data.output_names) == ["inclination"]
    assert data.unit("velocity_command") == "rad/s"
    assert data.unit("inclination") == "deg"
    assert data.name == bag.name
    assert load_rosbag(bag, CHANNELS, name="trial 3").name == "trial 3"


@needs_rosbags
def test_default_grid_is_the_slowest_period_over_the_overlap(bag: Path) -> None:
    data = load_rosbag(bag, CHANNELS)
    # Slowest channel: /imu/tilt at 50 Hz. Overlap: from its first header stamp (0.105 s) to its
    # last (1.885 s), inside /motor/cmd's 0 to 1.99 s.
    assert data.ts == TILT_PERIOD  # the median step in integer nanoseconds, 20_000_000
    assert data.t0 == pytest.approx(TILT_FIRST, abs=1e-12)
    assert data.n_samples == N_TILT


@needs_rosbags
def test_values_match_the_signals_to_interpolation_accuracy(bag: Path) -> None:
    data = load_rosbag(bag, CHANNELS)
    grid = data.time
    # The grid falls on the /imu/tilt stamps: its values come through unchanged.
    np.testing.assert_allclose(data.channel("inclination"), tilt_x(grid), atol=1e-9)
    # The grid falls halfway between /motor/cmd messages: linear interpolation of a sine of
    # angular frequency w with step h errs by at most w^2 h^2 / 8.
    bound = (2 * np.pi * FREQUENCY) ** 2 * CMD_PERIOD**2 / 8
    error = np.abs(data.channel("velocity_command") - command(grid))
    assert error.max() <= bound
    assert error.max() > bound / 4  # the grid is really off the command's stamps


@needs_rosbags
def test_given_ts_and_two_fields_of_one_topic(bag: Path) -> None:
    channels = {
        "velocity_command": RosbagChannel("/motor/cmd", "data", "input", "rad/s"),
        "tilt_x": ("/imu/tilt", "vector.x", "output"),
        "tilt_y": ("/imu/tilt", "vector.y", "output", "deg"),
    }
    data = load_rosbag(bag, channels, ts=0.013)
    assert data.ts == 0.013
    assert data.t0 == pytest.approx(TILT_FIRST, abs=1e-12)
    assert data.n_samples == math.floor((N_TILT - 1) * TILT_PERIOD / 0.013) + 1
    assert list(data.output_names) == ["tilt_x", "tilt_y"]
    assert list(data.output_units) == ["", "deg"]
    np.testing.assert_allclose(data.channel("tilt_y"), tilt_y(data.time), atol=1e-12)
    error = np.abs(data.channel("tilt_x") - tilt_x(data.time))
    assert error.max() <= 2 * (2 * np.pi * FREQUENCY) ** 2 * TILT_PERIOD**2 / 8


@needs_rosbags
def test_receive_times_shift_the_stamped_channel_by_its_latency(bag: Path) -> None:
    data = load_rosbag(bag, CHANNELS, stamps="receive")
    assert data.t0 == pytest.approx(TILT_FIRST + TILT_LATENCY, abs=1e-12)
    # Each value now sits at its receive time, TILT_LATENCY after the time it was measured.
    np.testing.assert_allclose(
        data.channel("inclination"), tilt_x(data.time - TILT_LATENCY), atol=1e-9
    )


@needs_rosbags
def test_array_fields_take_indexes(bag: Path) -> None:
    channels = {
        "tendon": ("/joint_states", "position[0]", "input", "m"),
        "motor": ("/joint_states", "position[-1]", "output", "rad"),
    }
    data = load_rosbag(bag, channels)
    assert data.ts == 0.04
    np.testing.assert_allclose(data.channel("tendon"), data.time, atol=1e-12)
    np.testing.assert_allclose(data.channel("motor"), 10.0 * data.time, atol=1e-11)


@needs_rosbags
def test_a_gap_is_bridged_with_a_warning(bag: Path) -> None:
    with pytest.warns(UserWarning, match=r"topic '/gappy' has 1 gap\(s\).*widest 0\.75 s"):
        data = load_rosbag(bag, {"ramp": ("/gappy", "data", "input")})
    np.testing.assert_allclose(data.channel("ramp"), data.time, atol=1e-12)


@needs_rosbags
def test_unfilled_header_stamps_can_be_replaced_by_receive_times(bag: Path) -> None:
    data = load_rosbag(bag, {"x": ("/unstamped", "vector.x", "input")}, stamps="receive")
    np.testing.assert_allclose(data.time, [0.2, 0.4, 0.6, 0.8], atol=1e-12)
    np.testing.assert_allclose(data.u.ravel(), [0.0, 1.0, 2.0, 3.0])


@needs_rosbags
@pytest.mark.skipif(
    HAVE_ROSBAGS
    and tuple(map(int, importlib.metadata.version("rosbags").split(".")[:2])) < (0, 11),
    reason="rosbags before 0.11 opens bag folders only",
)
def test_a_single_storage_file_reads_like_its_folder(bag: Path) -> None:
    (storage_file,) = [p for p in bag.iterdir() if p.suffix in (".db3", ".mcap")]
    from_file = load_rosbag(storage_file, CHANNELS)
    from_folder = load_rosbag(bag, CHANNELS)
    np.testing.assert_array_equal(from_file.u, from_folder.u)
    np.testing.assert_array_equal(from_file.y, from_folder.y)
    assert from_file.name == storage_file.name


@needs_rosbags
@pytest.mark.parametrize("storage", storages())
def test_custom_message_types_are_read_from_the_bag(tmp_path: Path, storage: str) -> None:
    from rosbags.typesys import get_types_from_msg

    types = typestore()
    types.register(
        get_types_from_msg("float64 length\nfloat64[3] tension\n", "neck_msgs/msg/TendonState")
    )
    tendon = types.types["neck_msgs/msg/TendonState"]
    messages = [
        (ns(0.01 * k), tendon(length=0.1 * k, tension=np.array([k, 2.0 * k, 3.0 * k])))
        for k in range(20)
    ]
    path = write_bag(
        tmp_path / "custom", storage, {"/tendon": ("neck_msgs/msg/TendonState", messages)}, types
    )
    data = load_rosbag(
        path,
        {
            "length": ("/tendon", "length", "input", "m"),
            "tension": ("/tendon", "tension[2]", "output", "N"),
        },
    )
    np.testing.assert_allclose(data.channel("length"), 10.0 * data.time, atol=1e-12)
    np.testing.assert_allclose(data.channel("tension"), 300.0 * data.time, atol=1e-9)


# --- bad input ------------------------------------------------------------------------------------

BAD_BAG_CONTENTS = [
    # (channels, options, exception, message pattern)
    pytest.param(
        {"x": ("/nope", "data", "input")},
        {},
        KeyError,
        r"run_\w+: topic '/nope' is not in the bag; its topics are .*'/imu/tilt'"
        r" \(geometry_msgs/msg/Vector3Stamped\), .*'/motor/cmd' \(std_msgs/msg/Float64\)",
        id="topic not in bag",
    ),
    pytest.param(
        {"x": ("/motor/cmd", "value", "input")},
        {},
        KeyError,
        r"topic '/motor/cmd', message index 0: field 'value' does not exist on"
        r" std_msgs/msg/Float64: .*its fields are \['data'\]",
        id="field not on type",
    ),
    pytest.param(
        {"x": ("/imu/tilt", "vector.w", "input")},
        {},
        KeyError,
        r"field 'vector.w' does not exist on geometry_msgs/msg/Vector3Stamped: 'vector' of"
        r" geometry_msgs/msg/Vector3Stamped is a geometry_msgs/msg/Vector3 with no field 'w';"
        r" its fields are \['x', 'y', 'z'\]",
        id="nested field not on type",
    ),
    pytest.param(
        {"x": ("/motor/cmd", "data[0]", "input")},
        {},
        KeyError,
        r"field 'data\[0\]' does not exist on std_msgs/msg/Float64: 'data' is a float.*cannot"
        r" take the index \[0\]",
        id="index into a number",
    ),
    pytest.param(
        {"x": ("/joint_states", "position[2]", "input")},
        {},
        ValueError,
        r"topic '/joint_states', message index 0: field 'position\[2\]': index 2 is out of range"
        r" for 'position', which holds 2 elements",
        id="index out of range",
    ),
    pytest.param(
        {"x": ("/status", "data", "input")},
        {},
        ValueError,
        r"topic '/status', message index 0: field 'data' of std_msgs/msg/String is not a number;"
        r" it holds a str \('ok'\)",
        id="string field",
    ),
    pytest.param(
        {"x": ("/imu/tilt", "vector", "input")},
        {},
        ValueError,
        r"field 'vector' of geometry_msgs/msg/Vector3Stamped is not a number; it holds a"
        r" geometry_msgs/msg/Vector3 .*name one of its numeric fields",
        id="message field",
    ),
    pytest.param(
        {"x": ("/joint_states", "position", "input")},
        {},
        ValueError,
        r"field 'position' .* is not a number; it holds a ndarray .*pick one element",
        id="array field",
    ),
    pytest.param(
        {"x": ("/nan", "data", "input")},
        {},
        ValueError,
        r"topic '/nan', message index 3: field 'data' holds the non-finite value nan",
        id="NaN value",
    ),
    pytest.param(
        {"x": ("/single", "data", "input")},
        {},
        ValueError,
        r"run_\w+: topic '/single' holds 1 message\(s\); a channel needs at least 2",
        id="one message",
    ),
    pytest.param(
        {"x": ("/motor/cmd", "data", "input"), "y": ("/late", "data", "output")},
        {},
        ValueError,
        r"run_\w+: the channels do not overlap in time .*'/motor/cmd' 0 to 1\.99 s,"
        r" '/late' 5 to 6 s",
        id="no overlap",
    ),
    pytest.param(
        {"x": ("/motor/cmd", "data", "input")},
        {"ts": 5.0},
        ValueError,
        r"the channels overlap for 1\.99 s only .* less than one period ts=5 s",
        id="overlap shorter than ts",
    ),
    pytest.param(
        {"x": ("/backwards", "vector.x", "input")},
        {},
        ValueError,
        r"topic '/backwards', message index 2: header.stamp 0\.25 s does not come after the"
        r" previous message's 0\.3 s \(1 such message\(s\)\); stamps must increase",
        id="stamps going back",
    ),
    pytest.param(
        {"x": ("/unstamped", "vector.x", "input")},
        {},
        ValueError,
        r"topic '/unstamped', message index 1: header.stamp .* stamps must increase; if the"
        r" publisher does not fill header.stamp, pass stamps='receive'",
        id="header stamps not filled",
    ),
]


@needs_rosbags
@pytest.mark.parametrize(("channels", "options", "error", "pattern"), BAD_BAG_CONTENTS)
def test_bad_bag_contents_are_refused(
    bag: Path, channels: dict, options: dict, error: type[Exception], pattern: str
) -> None:
    with pytest.raises(error, match=pattern) as caught:
        load_rosbag(bag, channels, **options)
    assert "\n" not in str(caught.value)


BAD_CHANNELS = [
    pytest.param({}, {}, ValueError, r"channels is empty", id="no channel"),
    pytest.param(
        [("/a", "data", "input")], {}, TypeError, r"channels must be a mapping", id="not a mapping"
    ),
    pytest.param(
        {"x": ("/a", "data", "state")},
        {},
        ValueError,
        r"channel 'x': kind must be 'input' or 'output'; got 'state'",
        id="bad kind",
    ),
    pytest.param(
        {"x": ("/a", "vector..x", "input")},
        {},
        ValueError,
        r"channel 'x': field 'vector\.\.x' is not a field path",
        id="bad field path",
    ),
    pytest.param(
        {"x": ("/a", "position[a]", "input")},
        {},
        ValueError,
        r"field 'position\[a\]' is not a field path",
        id="bad index",
    ),
    pytest.param(
        {"x": ("/a", "data")},
        {},
        TypeError,
        r"channel 'x' must be \(topic, field, kind\)",
        id="short",
    ),
    pytest.param(
        {"x": ("/a", 3, "input")}, {}, TypeError, r"channel 'x': field must be a string", id="type"
    ),
    pytest.param(
        {"y": ("/a", "data", "output")},
        {},
        ValueError,
        r"channels must include at least one kind 'input'; got only outputs \['y'\]",
        id="no input",
    ),
    pytest.param(
        {"x": ("/a", "data", "input")},
        {"stamps": "sent"},
        ValueError,
        r"stamps must be 'header' or 'receive'; got 'sent'",
        id="bad stamps",
    ),
    pytest.param(
        {"x": ("/a", "data", "input")},
        {"ts": -0.01},
        ValueError,
        r"ts must be a positive number of seconds; got -0\.01",
        id="bad ts",
    ),
]


@pytest.mark.parametrize(("channels", "options", "error", "pattern"), BAD_CHANNELS)
def test_bad_channels_are_refused_before_the_bag_is_read(
    tmp_path: Path, channels: dict, options: dict, error: type[Exception], pattern: str
) -> None:
    # The path does not exist: the channels are checked first, without rosbags.
    with pytest.raises(error, match=pattern):
        load_rosbag(tmp_path / "absent", channels, **options)


def make_empty_folder(path: Path) -> Path:
    path.mkdir()
    return path


def make_broken_metadata(path: Path) -> Path:
    path.mkdir()
    (path / "metadata.yaml").write_text("rosbag2_bagfile_information: [\n")
    return path


def make_junk_file(path: Path) -> Path:
    path.write_bytes(bytes(range(256)) * 4)
    return path


@needs_rosbags
@pytest.mark.parametrize(
    ("make", "filename", "pattern"),
    [
        (make_empty_folder, "empty", r"empty: cannot be opened as a ROS 2 bag: .*metadata"),
        (make_broken_metadata, "broken", r"broken: cannot be opened as a ROS 2 bag: .*YAML"),
        (make_junk_file, "junk.db3", r"junk\.db3: cannot be opened as a ROS 2 bag"),
        (make_junk_file, "junk.mcap", r"junk\.mcap: cannot be opened as a ROS 2 bag"),
        (make_junk_file, "notes.txt", r"notes\.txt: cannot be opened as a ROS 2 bag"),
    ],
)
def test_a_bag_that_cannot_be_opened(
    make: Any, filename: str, pattern: str, tmp_path: Path
) -> None:
    path = make(tmp_path / filename)
    with pytest.raises(ValueError, match=pattern) as caught:
        load_rosbag(path, CHANNELS)
    assert "\n" not in str(caught.value)


@needs_rosbags
def test_a_missing_bag(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match=r"absent: no such ROS 2 bag"):
        load_rosbag(tmp_path / "absent", CHANNELS)


def test_without_rosbags_the_error_says_how_to_install_it(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    # A None entry in sys.modules makes `import rosbags...` fail as if it were not installed.
    for module in [m for m in sys.modules if m == "rosbags" or m.startswith("rosbags.")]:
        monkeypatch.delitem(sys.modules, module)
    monkeypatch.setitem(sys.modules, "rosbags", None)
    with pytest.raises(ImportError, match=f"^{re.escape(ROSBAGS_MISSING)}$"):
        load_rosbag(tmp_path / "run", CHANNELS)
    assert ROSBAGS_MISSING == (
        "reading ROS 2 bags needs the optional dependency rosbags: pip install 'neckid[ros]'"
    )


@needs_rosbags
def test_a_broken_rosbags_install_is_not_reported_as_missing(tmp_path: Path) -> None:
    # rosbags is there but one of its own dependencies (lz4) is not: that error must come through.
    code = (
        "import sys\n"
        "sys.modules['lz4'] = None\n"
        "from neckid.datasets import load_rosbag\n"
        "try:\n"
        f"    load_rosbag({str(tmp_path)!r}, {{'x': ('/a', 'data', 'input')}})\n"
        "except ImportError as error:\n"
        "    print(error.name, '|', error)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.startswith("lz4"), done.stdout + done.stderr
    assert "neckid[ros]" not in done.stdout


def test_importing_the_loader_does_not_import_rosbags() -> None:
    code = "import sys, neckid.datasets; print('rosbags' in sys.modules)"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "False"


# --- the command line ----------------------------------------------------------------------------


@needs_rosbags
def test_the_command_line_identifies_and_validates_on_a_bag(bag: Path, tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from neckid.cli import app

    channels = ["--channel", "cmd=/motor/cmd:data:input:rad/s",
                "--channel", "tilt=/imu/tilt:vector.x:output:deg"]  # fmt: skip
    model = tmp_path / "bag_model.npz"
    runner = CliRunner()
    done = runner.invoke(app, ["identify", str(bag), "--layout", "rosbag", *channels,
                               "--method", "arx", "--lags", "1/1", "--save", str(model)])  # fmt: skip
    assert done.exit_code == 0, done.output
    assert "fit %" in done.output and model.exists()
    done = runner.invoke(app, ["validate", str(model), str(bag), "--layout", "rosbag", *channels])
    assert done.exit_code == 0, done.output
    assert "RMSE [deg]" in done.output
    done = runner.invoke(app, ["identify", str(bag), "--layout", "rosbag", "--method", "arx",
                               "--lags", "1/1", "--save", str(tmp_path / "m2.npz")])  # fmt: skip
    assert done.exit_code == 2 and "needs --channel" in done.output


@needs_rosbags
def test_info_describes_a_bag(bag: Path) -> None:
    import json

    from typer.testing import CliRunner

    from neckid.cli import app

    runner = CliRunner()
    channels = ["--channel", "cmd=/motor/cmd:data:input:rad/s",
                "--channel", "tilt=/imu/tilt:vector.x:output:deg"]  # fmt: skip
    done = runner.invoke(app, ["info", str(bag), "--layout", "rosbag", *channels, "--json"])
    assert done.exit_code == 0, done.output
    described = json.loads(done.output)
    assert set(described["channels"]) == {"cmd", "tilt"}
    assert described["channels"]["tilt"]["unit"] == "deg"
    missing = runner.invoke(app, ["info", str(bag), "--layout", "rosbag"])
    assert missing.exit_code == 2 and "--channel is required" in missing.output
