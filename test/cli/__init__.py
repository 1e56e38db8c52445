"""Unit tests of gear_phm.cli, one module per source module."""
