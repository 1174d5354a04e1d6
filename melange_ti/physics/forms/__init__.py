"""The step's parallel and device forms, each giving the serial form's bits: contiguous groups
solved side by side (:mod:`.groups`), islands of touching icebergs (:mod:`.islands`), the
device's parts with no work on one thread but block sums (:mod:`.device`). They stand on
the step (:mod:`..step`), which imports none of them."""
