"""Tests of coop_ga.sweep (issue 16)."""
