"""Edge utilities: JAX set-up, files, logging."""
