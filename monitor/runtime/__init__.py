"""Process plumbing the use cases share: worker pools, progress on long work, stage timings."""
