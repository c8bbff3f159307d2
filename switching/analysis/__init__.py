"""Questions asked of a model beyond one run: the divergence-of-time check
(:mod:`.verify`), forward sensitivities (:mod:`.sensitivity`, :mod:`.sensitivity_run`),
least-squares fits (:mod:`.fitting`), periodic orbits (:mod:`.orbits`), their continuation in
one parameter (:mod:`.continuation`) and small-signal models of a mode or an orbit (:mod:`.linear`).
"""
