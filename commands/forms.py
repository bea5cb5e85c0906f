"""The admin's command form, built from the catalog: one field per parameter of each kind.

All fields are on the page; a few lines of script show only the chosen kind's fields (without
script, the form still works: only the chosen kind's fields are read).
"""

from __future__ import annotations

from typing import Any

from django import forms

from commands import catalog
from commands.errors import CatalogError, CommandError
from commands.models import Command
from commands.services import command_validate, fence_set_params
from vessels.models import Mission, Vessel


def field_name(kind: str, param: str) -> str:
    return f"{kind}__{param}"


def add_command_error(form: forms.BaseForm, exc: CommandError, *, kind: str | None) -> None:
    """Put a commands-app error on the form field it names, or on the form as a whole.

    The one adapter from the app's errors to form errors (the API's is ``fleet.api``): a
    catalog error names a parameter of ``kind``, shown on that kind's field when it has one.
    """
    target = None
    if isinstance(exc, CatalogError) and exc.field:
        target = (
            exc.field if exc.field in {"kind", "mission"} else field_name(kind or "", exc.field)
        )
    form.add_error(target if target in form.fields else None, exc.message)


def _form_field(param: catalog.Param) -> forms.Field:
    common: dict[str, Any] = {"required": False, "help_text": param.help, "label": param.name}
    if param.kind == "float":
        return forms.FloatField(min_value=param.minimum, max_value=param.maximum, **common)
    if param.kind == "int":
        return forms.IntegerField(min_value=param.minimum, max_value=param.maximum, **common)
    if param.kind == "choice":
        return forms.ChoiceField(choices=[("", "—")] + [(c, c) for c in param.choices], **common)
    if param.kind == "bool":
        return forms.BooleanField(**common)
    if param.kind == "indices":
        common["help_text"] += " (space or comma separated)"
        return forms.CharField(**common)
    raise ValueError(f"no form field for {param.kind}")  # items: handled as a Mission choice


class CommandForm(forms.ModelForm):
    mission = forms.ModelChoiceField(
        Mission.objects.all(),
        required=False,
        help_text="For kind 'mission': the mission whose waypoints to send.",
    )

    class Meta:
        model = Command
        fields = ["vessel", "kind", "expires_at", "urgent"]

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.fields["kind"].widget.attrs["data-command-kind"] = "1"
        self.fields["expires_at"].help_text = "Empty: the default lifetime."
        self.param_fields: dict[str, list[str]] = {}
        for kind in catalog.KINDS.values():
            names = []
            for param in kind.params:
                # A mission's items and end come from the chosen Mission (as_params), a
                # fence set from the vessel's fences (fence_set_params).
                if param.kind in ("items", "fences") or (
                    kind.name == "mission" and param.name in {"loop", "end"}
                ):
                    continue
                name = field_name(kind.name, param.name)
                self.fields[name] = _form_field(param)
                self.fields[name].widget.attrs["data-kind"] = kind.name
                names.append(name)
            self.param_fields[kind.name] = names
        self.fields["mission"].widget.attrs["data-kind"] = "mission"

    def _params(self, kind: catalog.CommandKind, vessel: Vessel) -> dict[str, Any]:
        if kind.name == "fence" and vessel.kind in kind.vessel_kinds:
            return fence_set_params(vessel=vessel)
        params: dict[str, Any] = {}
        for param in kind.params:
            if kind.name == "mission":
                continue
            value = self.cleaned_data.get(field_name(kind.name, param.name))
            if value in (None, ""):
                continue
            if param.kind == "indices":
                try:
                    value = [int(v) for v in value.replace(",", " ").split()]
                except ValueError:
                    raise CatalogError(
                        f"{param.name} must be whole numbers", field=param.name
                    ) from None
            params[param.name] = value
        if kind.name == "mission":
            mission = self.cleaned_data.get("mission")
            if mission is None:
                raise CatalogError("choose a mission", field="mission")
            params = mission.as_params()
        return params

    def clean(self) -> dict[str, Any]:
        cleaned = super().clean()
        vessel: Vessel | None = cleaned.get("vessel")
        kind_name = cleaned.get("kind")
        if vessel is None or not kind_name:
            return cleaned
        try:
            kind = catalog.get_kind(kind_name)
            valid, _expires_at = command_validate(
                vessel=vessel,
                kind=kind_name,
                params=self._params(kind, vessel),
                expires_at=cleaned.get("expires_at"),
            )
        except CommandError as exc:
            add_command_error(self, exc, kind=kind_name)
            return cleaned
        cleaned["params"] = valid.params
        return cleaned
