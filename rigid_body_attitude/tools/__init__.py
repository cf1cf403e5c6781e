"""Command-line tools over the core and session: replay, accuracy study, dataset converter."""
