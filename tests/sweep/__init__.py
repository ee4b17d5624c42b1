"""Tests of coop_ga.sweep."""
