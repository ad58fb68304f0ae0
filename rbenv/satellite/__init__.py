"""The plant: the satellite and its surroundings, whatever the task.

``plant`` (the :class:`~rbenv.satellite.plant.Plant` that steps them), ``actuators/`` (one module
each, behind one protocol), ``scene`` and ``scene_schema`` (the TOML scenes, shipped in
``rbenv/scenes/``), ``orbit`` and ``disturbances`` (the torques of the surroundings),
``sensing`` (what is measured), ``allocation`` (torque to thrusters),
``randomization``, ``draws`` and ``torch_draws`` (episode starts from counter-based streams),
``state`` (the typed state each part declares) and ``usage`` (the wording of a bad choice).

This layer imports ``rbenv.core`` and nothing above it (tasks, env core, shells): the contract
in pyproject.toml, checked by tests/test_layers.py.
"""
