"""The model's data: the column and table types (:mod:`.columns`), and the schema built from
them and the effects' declarations, with the namespaces kernels index arrays with
(:mod:`.schema`)."""
