"""Unit tests of gear_phm.sources, one module per source module."""
