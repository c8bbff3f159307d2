"""Questions asked of a model beyond one run: the divergence-of-time check
(:mod:`.verify`), forward sensitivities (:mod:`.sensitivity`, :mod:`.sensitivity_run`)
and least-squares fits (:mod:`.fitting`).
"""
