"""Built-in robot models."""
