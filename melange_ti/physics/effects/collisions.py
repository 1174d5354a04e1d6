"""Iceberg-iceberg contact: normal impulses with restitution, found through the discs.

The contact law is shared with the wall; its code lives in the step's phases: detection in
:mod:`..step.narrow`, the impulse pass in :mod:`..step.impulses`, the overlap correction in
:mod:`..step.correction`. Its ledgers (``collision_dissipated``, ``correction_work``) are
run-wide accumulators (:data:`..data.schema.ACCUMULATORS`)."""

from .base import Effect

EFFECT = Effect(name="collisions", doc="iceberg-iceberg contact: instantaneous normal impulses with restitution")
