"""The app's views: each receives the :class:`app.document.Document` (or the data it draws) and redraws on its
events; none keeps a copy of the document."""
