"""Export warnings, each reported once (the engine reports them as WARNING).

Cached export results keep the warnings they produced (``items``) so that an export
that reuses them reports the same warnings as one that exported them afresh."""


class Warnings:
    def __init__(self):
        self.items = []  # (key, message) in the order they were first added
        self._seen = set()

    @property
    def messages(self):
        return [message for _, message in self.items]

    def add(self, key, message):
        if key in self._seen:
            return
        self._seen.add(key)
        self.items.append((key, message))

    def extend(self, items):
        for key, message in items:
            self.add(key, message)
