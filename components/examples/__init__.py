"""Non-robot example models: they prove the framework is generic."""
