"""Unit tests of gear_phm.paper, one module per source module."""
