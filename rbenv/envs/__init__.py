"""The Gymnasium side: the env core, its shells, their options and the registration of the ids.

From the top down (each imports only what is below it, and the tasks between the env core and
the options; the contract in pyproject.toml, checked by tests/test_layers.py):

- registration: ``registry`` (a :class:`~rbenv.tasks.spec.TaskSpec` becomes a Gymnasium id);
- shells: ``env`` (one satellite, on floats), ``vector_env`` (NumPy), ``torch_env`` (torch,
  loaded only by ``backend="torch"``) and ``goal`` (the goal-conditioned form);
- env core: ``transition`` (one step in a fixed order), ``adapter`` (what the shells share),
  ``vector`` (the vector contract: seeding, reset masks, autoreset), ``rendering`` and
  ``torch_compile``;
- ``options``: the env options, declared once, read by the tasks and every shell.

This file imports nothing, so that a task reading ``rbenv.envs.options`` loads no shell.
"""
