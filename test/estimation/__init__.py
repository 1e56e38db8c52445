"""Unit tests of gear_phm.estimation, one module per source module."""
