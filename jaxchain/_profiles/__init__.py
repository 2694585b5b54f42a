"""Sprocket tooth profiles: the kinds (ISO 606, free-form), the protocol every kind
implements (:mod:`.base`), their contact shapes, CAD export and files."""
