"""`fabhal lsp`: a language server for `.fhl` files (pygls 2; `pip install
'fabhal[lsp]'`, never imported otherwise). features.py answers each request
from the program as the editor holds it; server.py wires it to the protocol."""
