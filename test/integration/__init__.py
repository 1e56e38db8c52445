"""End-to-end tests: node processes over DDS, the CLI, bags written and read back."""
