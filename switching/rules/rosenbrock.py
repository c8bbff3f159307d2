"""The Rosenbrock method RODAS4P (Steinebach's coefficients, 1995, for the
scheme of RODAS4 in Hairer and Wanner, *Solving Ordinary Differential
Equations II*, §IV.7, and their code ``rodas.f``): its tableau, its continuous
extension and its step-size control.

RODAS4P keeps order 3 on the Prothero–Robinson problem ``y' = λ(y − φ(t)) +
φ'(t)`` for large ``|λ|`` (a stiff flow driven by inputs), where RODAS4's
coefficients drop to order 1–2 and its step control to tiny steps (measured:
751 steps for rtol 1e-8 at ``λ = −1000`` over 2 s, against 23 with these).

For ``y' = f(t, y)`` (``k`` states; ``t`` in the model's time unit) and a
step ``h`` from ``(t, y)``, with ``J = ∂f/∂y`` at ``(t, y)``, ``f_t = ∂f/∂t``
there (zero for a flow not driven by inputs) and the matrix

    E = I/(γ·h) − J                                   (γ = :data:`GAMMA`),

the six stages are the linear solves

    E·k_i = f(t + c_i·h, y + Σ_{j<i} a_ij·k_j) + Σ_{j<i} (C_ij/h)·k_j + h·d_i·f_t

(``a_6j = a_5j`` and ``a_65 = 1``: the last two stages are evaluated at the
embedded and the final solution, at ``t + h``), one LU of ``E`` per step.
The method is stiffly accurate and L-stable, of order 4 with an embedded
solution of order 3:

    ŷ = y + Σ_{j≤4} a_5j·k_j + k_5     (order 3),
    y₁ = ŷ + k_6                       (order 4),

so ``k_6 = y₁ − ŷ`` is the local error estimate, measured as scipy's
methods measure it: ``err = rms(k_6 / (atol + rtol·max(|y|, |y₁|)))`` (no
unit).  Dense output of order 3 (:func:`rodas_dense`) between ``y`` and
``y₁``, for ``θ = (τ − t)/h`` in [0, 1]:

    y(t + θh) ≈ (1 − θ)·y + θ·(y₁ + (1 − θ)·(q₁ + θ·q₂)),
    q₁ = Σ_{j≤5} H[0, j]·k_j,   q₂ = Σ_{j≤5} H[1, j]·k_j.

The step-size control (:func:`rodas_control`) is Hairer's: ``h_new = h /
clip(err^(1/4)/0.9, 1/6, 5)`` (so ``h_new/h`` lies in [0.2, 6]), with
Gustafsson's predictive factor after an accepted step that follows another
accepted one, ``(h_acc/h)·(err²/err_acc)^(1/4)/0.9`` (``h_acc``, ``err_acc``:
the last accepted step and its error, that error at least 1e-2), the
larger of the two reductions taken; no growth right after a rejection, and a
tenth of the step when the very first step is rejected.

Each rule is written component-wise on floats, so the kernel applies it to
each state and numba inlines it; in Python it applies to numpy arrays as
they are.
"""

from __future__ import annotations

import numpy as np

__all__ = ["A", "C", "D", "GAMMA", "GAMMA_C", "H", "ORDER", "RULES", "SAFETY", "rodas_control", "rodas_dense"]

RULES = ("rodas_control", "rodas_dense")

ORDER = 4  # the order of y₁ (the error estimate k₆ is of order 3: the step size goes as err^(1/4))
GAMMA = 0.25
SAFETY = 0.9
GROWTH = 6.0  # h_new/h at most
SHRINK = 0.2  # … and at least

#: the stages' times: t + C[i]·h
C = np.array([0.0, 0.75, 0.21, 0.63, 1.0, 1.0])
#: the stages' arguments: y + Σ_j A[i, j]·k_j (row 5: the embedded solution; then k₅ is added with weight 1)
A = np.array([
    [0.0, 0.0, 0.0, 0.0, 0.0],
    [3.0, 0.0, 0.0, 0.0, 0.0],
    [1.831036793486759, 0.4955183967433795, 0.0, 0.0, 0.0],
    [2.304376582692669, -0.05249275245743001, -1.176798761832782, 0.0, 0.0],
    [-7.170454962423024, -4.741636671481785, -16.31002631330971, -1.062004044111401, 0.0],
    [-7.170454962423024, -4.741636671481785, -16.31002631330971, -1.062004044111401, 1.0],
])
#: the couplings of the stages: Σ_j (GAMMA_C[i, j]/h)·k_j on the right-hand side of stage i
GAMMA_C = np.array([
    [0.0, 0.0, 0.0, 0.0, 0.0],
    [-12.0, 0.0, 0.0, 0.0, 0.0],
    [-8.791795173947035, -2.207865586973518, 0.0, 0.0, 0.0],
    [10.81793056857153, 6.780270611428266, 19.53485944642410, 0.0, 0.0],
    [34.19095006749676, 15.49671153725963, 54.74760875964130, 14.16005392148534, 0.0],
    [34.62605830930532, 15.30084976114473, 56.99955578662667, 18.40807009793095, -5.714285714285717],
])
#: the weights of h·f_t in each stage (a flow driven by inputs)
D = np.array([0.25, -0.5, -0.023504, -0.0362, 0.0, 0.0])
#: the dense output's coefficients q₁ = Σ_j H[0, j]·k_j, q₂ = Σ_j H[1, j]·k_j
H = np.array([
    [25.09876703708589, 11.62013104361867, 28.49148307714626, -5.664021568594133, 0.0],
    [1.638054557396973, -0.7373619806678748, 8.477918219238990, 15.99253148779520, -1.882352941176471],
])


def rodas_dense(y0, y1, q1, q2, theta):
    """The continuous extension at ``t + θ·h`` of a step from ``y0`` to
    ``y1`` with the dense coefficients ``q1``, ``q2``:
    ``(1 − θ)·y0 + θ·(y1 + (1 − θ)·(q1 + θ·q2))`` (``y0`` at θ = 0, ``y1``
    at θ = 1)."""
    rest = 1.0 - theta
    return rest * y0 + theta * (y1 + rest * (q1 + theta * q2))


def rodas_control(err, h_abs, h_acc, err_acc, rejected):
    """The step size after a step of size ``h_abs`` with the error norm
    ``err`` (accepted when ``err ≤ 1``; a NaN or infinite error is a
    rejection that divides the step by 5), ``h_acc`` and ``err_acc`` the last
    accepted step and its error (``h_acc`` 0: none yet), ``rejected``: the
    attempt before this one at the same point was rejected.  Returns
    ``(h_new, h_acc, err_acc)``, the last two updated when the step is
    accepted (see the module docstring)."""
    if not err <= 1e300:  # NaN or infinite: a failed step
        return h_abs * SHRINK, h_acc, err_acc
    quot = min(1.0 / SHRINK, max(1.0 / GROWTH, err**0.25 / SAFETY))
    if err > 1.0:
        if h_acc == 0.0:  # the first step rejected: a tenth of it
            return 0.1 * h_abs, h_acc, err_acc
        return h_abs / quot, h_acc, err_acc
    if h_acc > 0.0:  # Gustafsson's predictive control
        predicted = min(1.0 / SHRINK, max(1.0 / GROWTH, (h_acc / h_abs) * (err * err / err_acc) ** 0.25 / SAFETY))
        quot = max(quot, predicted)
    h_new = h_abs / quot
    if rejected:
        h_new = min(h_new, h_abs)
    return h_new, h_abs, max(1e-2, err)
