"""Fan-out for every world: the executor (local processes or a Dask address), the evaluation cache, the `compute:`
params section and the one cached-evaluation helper. Imports only robocompose.io."""
