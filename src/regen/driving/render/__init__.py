"""Pictures of a driving run: the map background, the actors, captions, GIFs and key frames.

Imports: ``world`` and ``verify`` of this domain and the shared core.
"""
