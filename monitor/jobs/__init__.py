"""Use cases: analyse one recording (for ``compare``, the batch and the service's worker alike), a fleet's
nightly batch, the service's analysis worker and the delivery of alerts."""
