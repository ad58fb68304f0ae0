"""rbenv agents: scripted controllers, the SB3 adapter, training, evaluation and reports.

Depends on rbenv and core, never the other way round. The ``rbenv`` console command is
:mod:`rbenv.agents.cli`.
"""
