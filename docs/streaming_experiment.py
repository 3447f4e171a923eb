"""streaming_ahead on the soft-neck test logs: 10-step (0.25 s) fit, updated every 1 s vs never.

Run from the repository: .venv/bin/python docs/streaming_experiment.py
"""

import sys
import time
import warnings

sys.path.insert(0, "/tmp")
import pandas as pd
from adaptive_experiment import TEST, TRAIN, load, models

from neckid.loops.adaptive import streaming_ahead

warnings.simplefilter("ignore")
train = [load(n) for n in TRAIN]
test = {n: load(n) for n in TEST}
rows = []
for method, model in models(train, True).items():
    model.fit(train)
    for name, data in test.items():
        for label, every in (("never", 10**9), ("every 1 s", None)):
            start = time.perf_counter()
            run = streaming_ahead(model, data, steps=10, update_every=every)
            rows.append(
                {
                    "method": method,
                    "test": name,
                    "update": label,
                    "fit": float(run.fit[0]),
                    "seconds": time.perf_counter() - start,
                }
            )
        print(rows[-2:], flush=True)
frame = pd.DataFrame(rows)
table = frame.pivot_table(index=["method", "update"], columns="test", values="fit", sort=False)
table["mean"] = table.mean(axis=1)
print("\n10-step-ahead fit [%] (payload condition), updated on what was seen")
print(table.round(1).to_string())
print(frame.groupby(["method", "update"], sort=False)["seconds"].mean().round(1).to_string())
