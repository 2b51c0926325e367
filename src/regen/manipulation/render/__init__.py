"""Pictures of a manipulation run: the trace replayed into a PyBullet scene, labeled frames, a
strip and a GIF.

Imports: ``world`` and ``simulation`` of this domain and the shared core and media writer.
"""
