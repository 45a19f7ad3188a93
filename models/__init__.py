"""Exact models in Pyomo, solved with HiGHS: optimal schedules and upper bounds."""
