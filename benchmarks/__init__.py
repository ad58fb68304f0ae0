"""Benchmarks: each module has a ``main()`` that writes JSON and PNG to ``benchmarks/results/``.

Run one with ``rbenv bench NAME`` or ``python -m benchmarks.NAME``, in a source checkout: the
folder is not installed, so an installed rbenv has no ``bench`` command.
"""
