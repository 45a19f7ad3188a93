"""Heuristic and search methods: ASA-DTC and its variants, and the paper's baselines."""
