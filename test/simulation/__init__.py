"""Unit tests of gear_phm.simulation, one module per source module."""
