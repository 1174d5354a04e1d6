"""The iceberg's shape as the kernels see it: its collision discs (:mod:`.discs`) and its exact
hydrostatics, the submerged part of the rectangle (:mod:`.hydrostatics`)."""
