"""Plumbing every layer shares; it imports nothing else from neckid.

Input checks (:mod:`~neckid.utils.checks`), safe file writing (:mod:`~neckid.utils.files`),
progress (:mod:`~neckid.utils.progress`), parallel sweeps (:mod:`~neckid.utils.parallel`), memory
estimates (:mod:`~neckid.utils.memory`), the numba cache (:mod:`~neckid.utils.numba_cache`), stop
signals taken at safe points (:mod:`~neckid.utils.interrupt`) and the array types
(:mod:`~neckid.utils.types`).
"""
