"""Blocks-world LLM planning experiment: tasks, plan parsing and validation, methods."""
