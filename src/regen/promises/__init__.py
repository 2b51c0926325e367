"""The promises every command keeps, in one home that every command uses.

- :mod:`.files`: opening a user's file (size cap, UTF-8 with or without a byte-order mark,
  decoding and parse errors as one line naming the file and the line or row).
- :mod:`.folders`: choosing an output folder (an existing file, a folder outside a run, a folder
  holding what the command did not write).
- :mod:`.names`: naming things on disk from user or model text (no separator, no ``..``, no
  absolute path, bounded length).
- :mod:`.terminal`: printing model or file text to a terminal (control and separator characters
  shown escaped).
- :mod:`.secrets`: a provider's error body redacted of every header value and key the request
  carried, before it is printed, logged or stored.

Callers import from the submodules; this package sits below :mod:`regen.core` and imports only
:mod:`regen.errors` and the standard library.
"""
