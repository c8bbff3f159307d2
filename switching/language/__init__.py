"""The guard and signal language: text parsed into sympy without executing
anything (:mod:`.parsing`), and sympy printed back to that text (:mod:`.exprtext`).
"""
