"""Molecules as a second domain for the string codec and the masked decoder (needs RDKit).

A molecule's heavy-atom skeleton is a typed graph: atoms are nodes typed by element, bonds are
edges (bond orders and hydrogens are left out). Valences play the role of the neighbour rules:
an atom of element E has 1..valence(E) neighbours (`TopologyRules.from_valences`). A skeleton
that obeys them is a valid molecule: RDKit sanitises it with single bonds and implicit
hydrogens, which `is_valid_molecule` checks independently of grammarkit's own rules.

`load_molecules` reads the molecules RDKit ships (`Data/NCI/first_5K.smi`, the first 5,000
NCI compounds): nothing is downloaded.
"""
from __future__ import annotations

from pathlib import Path

from grammarkit.errors import GrammarkitError

from .graphs import TypedGraph
from .topology import TopologyRules

__all__ = ["VALENCES", "is_valid_molecule", "load_molecules", "molecule_graph", "molecule_rules", "to_smiles"]

# Largest number of single bonds of a neutral atom (RDKit's default valences, the highest).
VALENCES = {"B": 3, "Br": 1, "C": 4, "Cl": 1, "F": 1, "I": 1, "N": 3, "O": 2, "P": 5, "S": 6}


def _rdkit():  # noqa: ANN202
    try:
        from rdkit import Chem, RDLogger
    except ImportError:
        raise GrammarkitError("molecules need RDKit, which is not installed: python -m pip install rdkit") from None
    RDLogger.DisableLog("rdApp.*")
    return Chem


def molecule_graph(mol) -> TypedGraph:  # noqa: ANN001
    """The heavy-atom skeleton of an RDKit molecule."""
    types = [a.GetSymbol() for a in mol.GetAtoms()]
    return TypedGraph.make(types, [(b.GetBeginAtomIdx(), b.GetEndAtomIdx()) for b in mol.GetBonds()])


def molecule_rules(types=None) -> TopologyRules:  # noqa: ANN001
    """Valence rules over the given elements (default: all of VALENCES)."""
    names = sorted(types) if types is not None else sorted(VALENCES)
    unknown = [t for t in names if t not in VALENCES]
    if unknown:
        raise GrammarkitError(f"no valence known for element(s) {', '.join(unknown)}")
    return TopologyRules.from_valences({t: VALENCES[t] for t in names}, name="molecule-valences")


def to_smiles(graph: TypedGraph) -> str | None:
    """SMILES of the skeleton with single bonds and implicit hydrogens; None if RDKit refuses it."""
    Chem = _rdkit()
    rw = Chem.RWMol()
    for t in graph.types:
        rw.AddAtom(Chem.Atom(t))
    for a, b in graph.edges:
        rw.AddBond(a, b, Chem.BondType.SINGLE)
    mol = rw.GetMol()
    try:
        Chem.SanitizeMol(mol)
    except Exception:  # noqa: BLE001 - RDKit raises several exception types for bad valences
        return None
    return Chem.MolToSmiles(mol)


def is_valid_molecule(graph: TypedGraph) -> bool:
    """Does RDKit accept the skeleton as a molecule (single bonds, implicit hydrogens)?"""
    return to_smiles(graph) is not None


def load_molecules(limit: int = 500, *, elements=None) -> list[tuple[str, TypedGraph]]:  # noqa: ANN001
    """(SMILES, skeleton) of up to `limit` molecules shipped with RDKit: neutral, one fragment,
    only the given elements (default: VALENCES), every atom within its valence."""
    Chem = _rdkit()
    from rdkit import RDConfig

    path = Path(RDConfig.RDDataDir) / "NCI" / "first_5K.smi"
    if not path.exists():
        raise GrammarkitError(f"{path}: RDKit's sample molecules are missing from this RDKit installation")
    allowed = set(elements or VALENCES)
    out: list[tuple[str, TypedGraph]] = []
    for line in path.read_text(encoding="utf-8").splitlines():
        if len(out) >= limit:
            break
        smi = line.split()[0] if line.strip() else ""
        mol = Chem.MolFromSmiles(smi) if smi else None
        if mol is None or mol.GetNumAtoms() < 2 or "." in smi:
            continue
        if any(a.GetFormalCharge() or a.GetSymbol() not in allowed for a in mol.GetAtoms()):
            continue
        g = molecule_graph(mol)
        deg = [0] * len(g)
        for a, b in g.edges:
            deg[a] += 1
            deg[b] += 1
        if any(d > VALENCES[t] for d, t in zip(deg, g.types)):
            continue
        out.append((smi, g))
    return out
