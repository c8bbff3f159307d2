"""The documentation of :meth:`~switching.model.hybrid_model.HybridModel.simulate`:
its methods, outputs and options, one text that ``help(model.simulate)`` shows.
(The options' kinds, bounds and units are checked in :mod:`switching.simulate.run_options`.)"""

SIMULATE_DOC = """Simulate from the initial state (or ``x0=``) to ``t_end``; returns a
:class:`~switching.simulate.trajectory.Trajectory`.

``method``: ``"euler"`` or ``"rk4"`` with step ``dt=``; ``"RK45"``,
``"RK23"``, ``"DOP853"``, ``"Radau"``, ``"BDF"``, ``"LSODA"`` with
``rtol=``, ``atol=`` (and ``max_step=``, ``first_step=``; ``atol`` in
the states' units, the same for all, or by default each state's own:
1e-9 in its storage's output's units — V, A, m/s, N — times the
storage's capacity, :mod:`switching.simulate.state_tolerances`, so
``rtol`` holds on a 10 pF capacitor as on a 1 kg mass);
``"euler-jit"``, ``"rk4-jit"``, ``"RK45-jit"``: the same in one
compiled kernel (numba; compiled once per installation, each mode's
functions compiled on first use), see :meth:`compiled_model`
(``progress`` is then called at each return of the kernel, not at
every step; inputs must be expressions of ``t``, ExpressionInput);
``"rodas-jit"``: the implicit Rosenbrock method RODAS4P (order 4) in
that kernel, with each mode's Jacobian derived symbolically, for
stiff scenes (``rtol=``, ``atol=``);
``"auto"``: the compiled kernel when its compilation is cached, paid
for by the run's expected length (as its load into a process that has
not run it yet: numba's import, ≈ 0.3 s), or the initial mode is stiff — RK45
in each mode, RODAS4P in the modes whose Jacobian's spectrum says
stiff — else ``"RK45"`` (``"Radau"`` for a stiff initial mode, and
where a flow of RK45 proves stiff; ``stats`` says which and why).

Output (the trajectory's rows; ``trajectory.sampling`` says which):

* default, ``output="steps"``: every integrator step, the start, the
  end, and every instant's two rows (just before, just after) — the
  solver's own steps, so few on a smooth flow (read a peak between
  them with ``samples=`` or ``t_eval=``); ``output="events"``: only
  the start, the instants' rows and the end;
* ``t_eval=ts`` (times [s] in ``[t0, t_end]``): exactly one row per
  requested time, ``trajectory.t
  == np.sort(ts)``, the states there read from the steps' dense
  output (as scipy's ``solve_ivp``), for the Python and compiled
  methods alike.  A time equal to an instant's gets the state just
  after it (right-continuous: the instant has happened at its time);
  the states just before and after every instant are
  ``trajectory.at_instants()`` (and ``trajectory.events``).  A run
  that stops before ``t_end`` (``on_zeno="stop"``, or the partial
  run of an error) has the times it reached, then the state where it
  stopped;
* ``samples=N`` (``hbg run``'s default, ``N = 500``): the ``N``
  times ``linspace(t0, t_end, N)`` as with ``t_eval``, and every
  instant's before and after rows, in time order (at a time on an
  instant: before, after, then the time's row, equal to after) —
  dense uniform rows with the jumps upright, for plots;
  ``trajectory.without_instants()`` leaves the ``N`` times.  ``hbg run
  --samples N --with-instants`` writes exactly these rows, ``hbg run
  --samples N`` their ``N`` times (``t_eval=linspace(0, t_end, N)``).

``on_zeno="raise"`` (default) or ``"stop"``.
``progress``: a callable receiving the time after every step, or
``True`` for a progress bar on stderr once the run takes over 2 s.
``keep_instants=False`` keeps neither the instants' records nor their
samples (only their count, ``trajectory.instant_count``, and the time
spent in each mode, ``time_in_modes()``): with ``t_eval`` or
``output="events"`` the memory of a long run then stays bounded.
``t_end`` and ``t_eval`` must be finite, ``t_eval`` inside the run;
``samples`` a whole number ≥ 2, not together with ``t_eval``.
``max_steps`` (default 10 000 000) bounds the steps of a run: options
implying more (``(t_end − t0)/dt``, ``(t_end − t0)/max_step``), a
step below the resolution of ``t`` (``t + dt == t``), too many guard
samples or sample times are refused before anything runs
(:class:`~switching.errors.WorkLimitError`), and a run that takes
more steps stops with :class:`~switching.errors.StepLimitError`.
Every option is checked, its kind and bounds, before anything runs
(:mod:`switching.simulate.run_options` lists them with their units).
A failed run raises a :class:`~switching.errors.SimulationError`
carrying the trajectory computed so far (``error.trajectory``);
Ctrl-C raises :class:`~switching.errors.SimulationInterrupted`, a
``KeyboardInterrupt`` that carries it too.  A flow that would start
from non-finite rates or guard sides (a zero inductance) raises
:class:`~switching.errors.NonFiniteStateError` naming them at once.
``event_samples`` (default 3): guards are also tested at this many
interior points of every step, and searched between them (an
extremum of a comparison that comes within reach of its threshold,
two comparisons of one guard changing truth), so a guard holding only
briefly inside a step is still found — by the Python methods and the
``*-jit`` kernels alike.
``stiffness_check=False`` turns off the stiffness tests of the
explicit methods (the run then goes on whatever the stability of the
step; Python and compiled methods alike).
Discontinuous element laws (``sign``, ``Heaviside``, ``Piecewise``)
are law switches (:mod:`switching.model.law_automata`): their crossings are
located as events and a state held on a surface slides on it.
``sensitivities=["e", "x0:y"]``: also the forward sensitivities
``∂x/∂p`` of the run through its instants, with respect to model
parameters and (``x0:<state>``) initial states
(:mod:`switching.analysis.sensitivity`; ``sensitivity_rtol=``,
``sensitivity_atol=`` set the tolerances of their integration,
default 1e-10 and 1e-12): ``trajectory.sensitivity(name, p)``,
``trajectory.event_time_sensitivity(k, p)``.  Python methods only.
See :func:`switching.simulate.driver.simulate`.
"""
