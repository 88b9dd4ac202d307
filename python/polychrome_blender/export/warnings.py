"""Collects export warnings once each (the engine reports them as WARNING)."""


class Warnings:
    def __init__(self):
        self.messages = []
        self._seen = set()

    def add(self, key, message):
        if key in self._seen:
            return
        self._seen.add(key)
        self.messages.append(message)
