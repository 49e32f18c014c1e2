"""What a user reads: the model-order and diagnosis tables, JSON documents, plots, alert events and the
web pages."""
