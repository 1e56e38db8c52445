"""Unit tests of gear_phm.offline, one module per source module."""
