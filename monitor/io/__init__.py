"""Reading and writing recordings: the product's HDF5 and MCAP formats (recordings/FORMAT.md)."""
