"""Unit tests of gear_phm.models, one module per source module."""
