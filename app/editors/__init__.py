"""Editors: widgets generated from declarations (a model's parameter list) that write through the document."""
