"""Scripted baselines and the optimum: the tasks' controllers (:mod:`.controllers`, SB3's
``predict``), model-predictive control (:mod:`.mpc`), the open-loop trajectory optimisers
(:mod:`.optimal`, :mod:`.open_loop`) and the lower bounds on settle time and propellant that
every evaluation's optimality ratios divide by (:mod:`.bounds`). They depend on rbenv alone."""
