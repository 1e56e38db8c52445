"""Unit tests of gear_phm.bagio, one module per source module."""
