"""The HTTP service (FastAPI). Empty until the service is built: no endpoints yet."""
