"""Files other simulators load: the Scenic program, OpenSCENARIO with its OpenDRIVE map, the
paper's config form.

Imports: ``world``, ``primitives`` and ``simulation`` of this domain and the shared core.
"""
