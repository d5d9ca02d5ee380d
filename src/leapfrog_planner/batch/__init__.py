"""Many scenarios: seeded generation, sweeps on processes or a Dask cluster, reports."""
