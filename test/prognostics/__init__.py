"""Unit tests of gear_phm.prognostics, one module per source module."""
