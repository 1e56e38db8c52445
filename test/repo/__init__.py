"""Checks of the repository as a whole: linters, types, import graph, package.xml, docs."""
