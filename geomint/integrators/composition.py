"""Symmetric compositions of a symmetric second-order method, to orders 4, 6 and 8.

    Psi_h = Phi_{gamma_s h} o ... o Phi_{gamma_1 h},   gamma_{s+1-i} = gamma_i,   sum gamma_i = 1.

Every scheme is coefficient data (``SCHEMES``) on the one engine in
``geomint._kernels.composition``; composing ``Gonzalez()`` gives energy-exact
methods of order 4, 6, 8.  All real schemes above order 2 have negative gammas
(Blanes, Casas, Chartier, Murua, arXiv:1102.1622), so some sub-steps run the
gradient flow backwards and raise S; ``monotone=True`` redoes any full step
that raised S with ``Gonzalez()`` (order 2, never raises S).
Coefficients from Hairer's ``gni_comp.f`` (docs/references.md); see Hairer, Lubich,
Wanner, *Geometric Numerical Integration*, section V.3.
"""

from dataclasses import dataclass, field
from decimal import Decimal, localcontext
from typing import ClassVar

from .base import Integrator, Traits
from .discrete_gradient import Gonzalez
from .program import Program, Programmed, program_of

_DIGITS = 40


def _closed_form_4(root_of, stages):
    """``gamma_1 = .. = gamma_{m} = 1/(2m - (2m)^(1/3))``, middle ``-(2m)^(1/3) gamma_1``, ``m = (stages-1)/2``."""
    with localcontext() as ctx:
        ctx.prec = _DIGITS
        m = (stages - 1) // 2
        root = Decimal(root_of) ** (Decimal(1) / Decimal(3))
        outer = Decimal(1) / (Decimal(2 * m) - root)
        return (outer,) * m + (-root * outer,)


#: name -> (order, source, first half of the gammas up to the middle one, as Decimals)
SCHEMES = {
    "yoshida4": (4, "Yoshida 1990, doi:10.1016/0375-9601(90)90092-3", _closed_form_4(2, 3)),
    "suzuki4": (4, "Suzuki 1990, doi:10.1016/0375-9601(90)90962-N", _closed_form_4(4, 5)),
    "yoshida6": (
        6,
        "Yoshida 1990, doi:10.1016/0375-9601(90)90092-3",
        tuple(
            map(
                Decimal,
                (
                    "0.78451361047755726381949763",
                    "0.23557321335935813368479318",
                    "-1.17767998417887100694641568",
                    "1.31518632068391121888424973",
                ),
            )
        ),
    ),
    "kahan_li6": (
        6,
        "Kahan and Li 1997, doi:10.1090/S0025-5718-97-00873-9",
        tuple(
            map(
                Decimal,
                (
                    "0.39216144400731413927925056",
                    "0.33259913678935943859974864",
                    "-0.70624617255763935980996482",
                    "0.08221359629355080023149045",
                    "0.79854399093482996339895035",
                ),
            )
        ),
    ),
    "suzuki_umeno8": (
        8,
        "Suzuki and Umeno 1993; McLachlan 1995, doi:10.1137/0916010",
        tuple(
            map(
                Decimal,
                (
                    "0.74167036435061295344822780",
                    "-0.40910082580003159399730010",
                    "0.19075471029623837995387626",
                    "-0.57386247111608226665638773",
                    "0.29906418130365592384446354",
                    "0.33462491824529818378495798",
                    "0.31529309239676659663205666",
                    "-0.79688793935291635401978884",
                ),
            )
        ),
    ),
    "kahan_li8": (
        8,
        "Kahan and Li 1997, doi:10.1090/S0025-5718-97-00873-9",
        tuple(
            map(
                Decimal,
                (
                    "0.13020248308889008087881763",
                    "0.56116298177510838456196441",
                    "-0.38947496264484728640807860",
                    "0.15884190655515560089621075",
                    "-0.39590389413323757733623154",
                    "0.18453964097831570709183254",
                    "0.25837438768632204729397911",
                    "0.29501172360931029887096624",
                    "-0.60550853383003451169892108",
                ),
            )
        ),
    ),
}


def gammas(scheme: str, exact: bool = False) -> tuple[float | Decimal, ...]:
    """All ``gamma_1 .. gamma_s`` of ``scheme`` (floats, or Decimals when ``exact``)."""
    half = SCHEMES[scheme][2]
    full = half + half[-2::-1]
    return full if exact else tuple(float(g) for g in full)


@dataclass(frozen=True)
class Composition(Programmed, Integrator):
    """``base`` composed with the coefficients of ``scheme`` (a key of ``SCHEMES``).

    Parameters
    ----------
    base : Integrator, default Gonzalez()
        Symmetric and of order 2: ``Gonzalez()``, ``Strang(...)``, ``RotorSplitting()``...
    scheme : str
        ``yoshida4`` (3 stages), ``suzuki4`` (5), ``yoshida6`` (7), ``kahan_li6`` (9),
        ``suzuki_umeno8`` (15), ``kahan_li8`` (17).
    monotone : bool, default False
        Guarantee ``S(x_{n+1}) <= S(x_n)``: a full step that raised S is redone
        with ``Gonzalez()`` (that step is then of order 2 and not symmetric).
        ``geomint.integrators.S_rise_statistics`` counts how often it fires.
    """

    base: Integrator = field(default_factory=Gonzalez)
    scheme: str = "yoshida4"
    monotone: bool = False

    name: ClassVar[str] = "composition"

    def __post_init__(self) -> None:
        if not isinstance(self.base, Integrator):
            raise TypeError(f"`base` must be a geomint Integrator; got {self.base!r}.")
        if not isinstance(self.scheme, str) or self.scheme not in SCHEMES:
            raise ValueError(f"`scheme` must be one of {sorted(SCHEMES)}; got {self.scheme!r}.")
        if not self.base.whole_field:
            raise ValueError(
                f"`base` must integrate the whole field; {self.base!r} integrates only the {self.base.flows[0]} flow."
            )
        if not (self.base.symmetric and self.base.order == 2):
            raise ValueError(
                f"`base` must be symmetric and of order 2 for {self.scheme!r} to reach order {self.order}; "
                f"{self.base!r} has symmetric={self.base.symmetric}, order={self.base.order}."
            )
        if not isinstance(self.monotone, bool):
            raise TypeError(f"`monotone` must be True or False; got {self.monotone!r}.")

    @property
    def traits(self) -> Traits:
        return Traits(
            order=SCHEMES[self.scheme][0],
            energy_exact=self.base.energy_exact,
            dissipative=self.monotone,
            symmetric=not self.monotone,
            implicit=self.base.implicit or self.monotone,
        )

    def program(self) -> Program:
        base = program_of(self.base)
        return Program(base.stages, gammas(self.scheme), self.monotone)

    def sub_methods(self) -> tuple[Integrator, ...]:
        return (self.base,)


def _wrapper(scheme_name, doc):
    cls = dataclass(frozen=True)(
        type(
            "".join(part.capitalize() for part in scheme_name.split("_")),
            (Composition,),
            {
                "__annotations__": {"scheme": str, "name": ClassVar[str]},
                "scheme": field(default=scheme_name, init=False),
                "name": scheme_name,
                "__doc__": doc,
                "__module__": __name__,
            },
        )
    )
    return cls


Yoshida4 = _wrapper("yoshida4", "Yoshida's triple jump, order 4 (3 stages): ``Composition(base, 'yoshida4')``.")
Suzuki4 = _wrapper("suzuki4", "Suzuki's fractal, order 4 (5 stages): ``Composition(base, 'suzuki4')``.")
Yoshida6 = _wrapper("yoshida6", "Yoshida's order-6 scheme (7 stages): ``Composition(base, 'yoshida6')``.")
KahanLi6 = _wrapper("kahan_li6", "Kahan and Li's order-6 scheme (9 stages): ``Composition(base, 'kahan_li6')``.")
SuzukiUmeno8 = _wrapper("suzuki_umeno8", "Suzuki-Umeno order 8 (15 stages): ``Composition(base, 'suzuki_umeno8')``.")
KahanLi8 = _wrapper("kahan_li8", "Kahan and Li's order-8 scheme (17 stages): ``Composition(base, 'kahan_li8')``.")

WRAPPERS = (Yoshida4, Suzuki4, Yoshida6, KahanLi6, SuzukiUmeno8, KahanLi8)
