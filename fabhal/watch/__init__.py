"""`fabhal watch`: the live design loop. A save of the program (or of a file it
imports) solves it again (session.py); a small HTTP server on the loopback
address shows each result in the 3D viewer, updated in place (server.py);
the files are watched by directory, as editors save by renaming (files.py)."""
