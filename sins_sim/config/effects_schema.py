"""The ``effects:`` list of IMU files: one schema node, checked by the effects catalogue.

Item format (IMU files and experiment files, ``sins_sim.config.experiment``, share this node)::

    effects:
      - {name: lock_in, axes: [x], threshold_rad_s: 2.0e-3, phase_rad: 0.3}
      - {name: piezo_lag, tau_s: 1.0e-4}            # no axes: every axis

Parameters are in SI with the unit in the key (``sins_sim.models.effects``: ``tau_s``,
``threshold_rad_s``, ``frequency_hz``, ...); :func:`sins_sim.models.effects.make_effect` checks
names, ranges and unknown keys, so the file and the catalogue cannot disagree.
"""

from __future__ import annotations

from sins_sim.config.errors import ConfigError

__all__ = ["EffectsList", "ENGINE_AXES"]

#: The axes an IMU's effects may name.
ENGINE_AXES = ("x", "y", "z")


class EffectsList:
    """Schema node of an ``effects:`` list; ``check`` returns a tuple of catalogue ``Effect`` objects.

    Parameters
    ----------
    axes : tuple of str or None
        Axis names the items may list under ``axes`` (None: any; the file checks them against its
        own axes, as an experiment does).
    catalogue_only : bool
        Refuse the off-catalogue disturbances (``mains_pickup``, ``drive_harmonic``).
    doc : str
        Extra text for the reference row.
    """

    unit = None
    default = None
    required = False

    def __init__(self, axes=ENGINE_AXES, catalogue_only: bool = True, doc: str = ""):
        self.axes = None if axes is None else tuple(axes)
        self.catalogue_only = catalogue_only
        self.doc = doc

    def describe_rows(self, path):
        """One reference row (``sins_sim.config.schema.describe``)."""
        from sins_sim.models.effects import EFFECTS

        names = ", ".join(EFFECTS)
        return [{"key": path, "kind": "list", "unit": "", "range": "catalogue effects", "default": "(none)",
                 "doc": f"[{{name: EFFECT, axes: [...], SI parameters}}, ...]; EFFECT one of {names}; parameters: "
                        f"sins_sim.models.effects{'; ' + self.doc if self.doc else ''}"}]

    def json_schema(self):
        """JSON Schema for editors: a list of mappings with a catalogue ``name`` (parameters checked by the loader)."""
        from sins_sim.models.effects import EFFECTS

        item = {"type": "object", "required": ["name"],
                "properties": {"name": {"enum": list(EFFECTS)} if self.catalogue_only else {"type": "string"}}}
        if self.axes is not None:
            item["properties"]["axes"] = {"type": "array", "items": {"enum": list(self.axes)}}
        return {"type": ["array", "null"], "items": item,
                "description": "catalogue effects; parameters: sins_sim.models.effects"}

    def check(self, value, ctx, path):
        """Validate the list; one line naming the item and the rule on error."""
        if value is None:
            return ()
        # the catalogue (scipy, numba) only for a file that lists effects
        from sins_sim.models.effects import EFFECTS, make_effect

        if not isinstance(value, list):
            raise ConfigError(f"{ctx}: {path}: must be a list of effects, got {value!r}")
        out = []
        for i, item in enumerate(value):
            if not isinstance(item, dict) or "name" not in item:
                raise ConfigError(f"{ctx}: {path}[{i}]: must be a mapping with a 'name', got {item!r}")
            if not isinstance(item["name"], str):
                raise ConfigError(f"{ctx}: {path}[{i}].name: must be the name of an effect (one of {list(EFFECTS)}), "
                                  f"got {type(item['name']).__name__} {item['name']!r}")
            if self.catalogue_only and item["name"] not in EFFECTS:
                raise ConfigError(f"{ctx}: {path}[{i}].name: must be one of {list(EFFECTS)}, got {item['name']!r}")
            params = {k: v for k, v in item.items() if k != "name"}
            try:
                eff = make_effect(item["name"], **params)
                if self.axes is not None:
                    eff.check_axes(self.axes)
            except (ValueError, TypeError) as exc:
                raise ConfigError(f"{ctx}: {path}[{i}]: {exc}") from None
            for j, other in enumerate(out):  # one effect of a kind per axis: two would stack without a model
                if other.name == eff.name:
                    shared = _axes_of(eff, self.axes) & _axes_of(other, self.axes)
                    if shared:
                        raise ConfigError(f"{ctx}: {path}[{i}]: {eff.name} is already given for axis "
                                          f"{', '.join(sorted(shared))} by {path}[{j}]: give each axis one "
                                          f"{eff.name} (list the axes under axes:)")
            out.append(eff)
        return tuple(out)


def _axes_of(effect, axes) -> set:
    """The axes an effect acts on (every axis when it names none; any name when the file's axes are open)."""
    if effect.axes is not None:
        return set(effect.axes)
    coefficients = getattr(effect, "coefficients", None)
    if coefficients is not None:  # axis_coupling: its targets
        return set(coefficients)
    return set(axes) if axes is not None else {"*"}
