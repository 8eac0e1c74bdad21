"""The validation studies of tps_solver (a package of the source checkout, not of the wheel).

Each module is importable: its functions return the measured numbers (the tests
assert on them) and its ``main()`` prints the tables, writes its section of
``validation/REPORT.md`` and its figures.  Run one with ``python -m
validation.<module>`` from the checkout's root, or all of them with ``python -m
validation.run_all`` (``tps-solver validate``).
"""
