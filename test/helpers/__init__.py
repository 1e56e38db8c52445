"""Helpers shared by several test files (plants, node processes, bag comparison).

Test files import them as ``from helpers.<module> import ...``: pytest puts ``test/`` on
``sys.path`` (rootdir-relative imports, no ``__init__.py`` in ``test/``). Nothing here is
collected as a test.
"""
