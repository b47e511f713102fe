"""Applications on the runtime: the campaign on Dask and the report of a simulated run.
"""
