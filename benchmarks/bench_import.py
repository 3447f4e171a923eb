"""Start-up time: ``import neckid`` (lazy) vs loading its whole public API, and the CLI's ``--version``.

Run:  .venv/bin/python benchmarks/bench_import.py [--repeat 7]

Every timing is the wall time of a fresh interpreter (``python -c ...`` or the ``neckid`` entry
point), so it includes the interpreter's own start-up; the first line, ``python -c pass``, is that
floor. The interpreter is started once before timing so the disk cache is warm. Figures are medians
of ``--repeat`` runs, in milliseconds.
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

LOAD_PUBLIC_API = "import neckid; [getattr(neckid, name) for name in neckid.__all__]"


def cli_command() -> list[str]:
    """The ``neckid`` entry point installed beside this interpreter, or the same call through -c."""
    script = shutil.which("neckid", path=str(Path(sys.executable).parent))
    if script is not None:
        return [script]
    return [sys.executable, "-c", "from neckid.cli import app; app()"]


def median_ms(command: list[str], repeat: int) -> float:
    subprocess.run(command, check=True, capture_output=True)  # warm the disk cache
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        subprocess.run(command, check=True, capture_output=True)
        times.append(time.perf_counter() - start)
    return 1e3 * statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    args = parser.parse_args()

    cli = cli_command()
    cases = {
        "python -c pass": [sys.executable, "-c", "pass"],
        "import neckid": [sys.executable, "-c", "import neckid"],
        "import neckid + every name in __all__": [sys.executable, "-c", LOAD_PUBLIC_API],
        "neckid --version": [*cli, "--version"],
        "neckid --help": [*cli, "--help"],
    }
    medians = {}
    print(f"median wall time of a fresh process, {args.repeat} runs each:")
    for label, command in cases.items():
        medians[label] = median_ms(command, args.repeat)
        print(f"  {label:40s} {medians[label]:8.0f} ms")
    lazy = medians["import neckid"]
    eager = medians["import neckid + every name in __all__"]
    print(f"loading the whole public API takes {eager / lazy:.1f}x as long as `import neckid`")


if __name__ == "__main__":
    main()
