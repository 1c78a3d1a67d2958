#pragma once
// Deterministic layout of binary trees built by parallel tasks.
//
// Each task builds its subtree into a Piece of its own (nodes[0] = the subtree's root,
// children of a node stored side by side, child indices and leaf offsets local to the
// piece). A task that splits its work in two keeps only its root node and the two child
// pieces. flatten_pieces() then lays everything out depth first from the root, so the final
// arrays depend only on the tree, never on which thread built what or when. Every piece is
// copied exactly once.
//
// Traits must provide, for its Node type:
//   static bool is_leaf(const Node&);
//   static std::uint32_t child(const Node&);          // interior: index of the first child
//   static void set_child(Node&, std::uint32_t);
//   static void shift_leaf(Node&, std::uint32_t by);  // leaf: add `by` to its first reference
#include <cstdint>
#include <memory>
#include <vector>

namespace splitray {

template <class Node>
struct Piece {
  std::vector<Node> nodes;           // nodes[0] = root
  std::vector<std::uint32_t> prims;  // leaf references local to this piece (may stay empty)
  std::unique_ptr<Piece> kids[2];    // when kids[0] is set, nodes[0] is interior and its children
                                     // are these (kids[1] empty: a node with one child)
};

namespace detail {

template <class Traits, class Node>
void count_pieces(const Piece<Node>& piece, std::size_t& nodes, std::size_t& prims) {
  prims += piece.prims.size();
  if (piece.kids[0]) {
    nodes += 1;
    for (const auto& kid : piece.kids)
      if (kid) count_pieces<Traits>(*kid, nodes, prims);
  } else {
    nodes += piece.nodes.size();
  }
}

template <class Traits, class Node>
void place_piece(const Piece<Node>& piece, std::size_t slot, std::vector<Node>& nodes,
                 std::vector<std::uint32_t>& prims) {
  if (piece.kids[0]) {
    const auto first = static_cast<std::uint32_t>(nodes.size());
    nodes.resize(nodes.size() + (piece.kids[1] ? 2 : 1));
    Node root = piece.nodes[0];
    Traits::set_child(root, first);
    nodes[slot] = root;
    place_piece<Traits>(*piece.kids[0], first, nodes, prims);
    if (piece.kids[1]) place_piece<Traits>(*piece.kids[1], first + 1, nodes, prims);
    return;
  }
  // Local node i >= 1 goes to base + i - 1; local prims are appended after the current ones.
  const auto base = static_cast<std::uint32_t>(nodes.size());
  const auto prim_base = static_cast<std::uint32_t>(prims.size());
  prims.insert(prims.end(), piece.prims.begin(), piece.prims.end());
  nodes.insert(nodes.end(), piece.nodes.begin() + 1, piece.nodes.end());
  const auto fix = [&](Node& n) {
    if (Traits::is_leaf(n)) {
      if (prim_base != 0) Traits::shift_leaf(n, prim_base);
    } else {
      Traits::set_child(n, base + Traits::child(n) - 1);
    }
  };
  nodes[slot] = piece.nodes[0];
  fix(nodes[slot]);
  for (std::size_t i = base; i < nodes.size(); ++i) fix(nodes[i]);
}

}  // namespace detail

// Lays out a piece tree into `nodes` (root at 0) and `prims`.
template <class Traits, class Node>
void flatten_pieces(const Piece<Node>& root, std::vector<Node>& nodes,
                    std::vector<std::uint32_t>& prims) {
  std::size_t node_count = 0, prim_count = 0;
  detail::count_pieces<Traits>(root, node_count, prim_count);
  nodes.clear();
  prims.clear();
  nodes.reserve(node_count);
  prims.reserve(prim_count);
  nodes.resize(1);
  detail::place_piece<Traits>(root, 0, nodes, prims);
}

}  // namespace splitray
