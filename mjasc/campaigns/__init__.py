"""Monte Carlo campaigns on Dask."""
