"""Unit tests of gear_phm's top-level modules (gear_phm/*.py), one module per source module.

Not named ``gear_phm``: pytest puts ``test/`` on ``sys.path``, where a folder of that name would
shadow the package.
"""
