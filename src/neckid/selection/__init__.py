"""Which model: one package for choosing lags, settings and methods on the training logs.

The lag search and candidate scoring (:mod:`~neckid.selection.lags`), He & Asada's Lipschitz
index (:mod:`~neckid.selection.lipschitz`), safe selection and the comparison on test logs
(:mod:`~neckid.selection.comparison`). The folds they score on are :mod:`neckid.data.folds`.
"""
