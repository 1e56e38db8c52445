"""Reproduction of the figures of Berri et al. (see docs/paper-reproduction.md)."""
