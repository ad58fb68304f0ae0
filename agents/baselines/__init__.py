"""Scripted baselines: the tasks' controllers (:mod:`.controllers`, SB3's ``predict``) and the
open-loop trajectory optimiser (:mod:`.optimal`). They depend on rbenv alone."""
