"""Unit tests of gear_phm.nodes without DDS, one module per source module."""
