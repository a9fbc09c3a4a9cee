// SPDX-License-Identifier: Apache-2.0
#include "mgc/planning/path_shortener.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>

namespace mgc::planning {

PathShortener::PathShortener(int dof, std::size_t capacity, double chunk_m, int max_orders)
    : chunk_m_(std::max(chunk_m, 1e-3)), capacity_(std::max<std::size_t>(capacity, 2)), max_orders_(std::max(max_orders, 1)) {
  const JointVector zero = JointVector::Zero(dof);
  step_ = zero;
  // Reserved, not filled: the nodes are written as a path comes in, so only the memory a path
  // uses is ever touched (filling the whole capacity costs more than shortening a short path).
  nodes_.reserve(capacity_);
  source_.reserve(capacity_);
  stairs_.assign(static_cast<std::size_t>(dof), zero);
  at_ = zero;
  chunk_to_ = zero;
  end_ = zero;
}

double PathShortener::delta(int j, const JointVector& from, const JointVector& to) const noexcept {
  const double d = to[j] - from[j];
  // The way MachineModel::difference turns, half a turn included, so that the stairs walked here
  // are the edges the path's users interpolate.
  return world_->model().joints()[static_cast<std::size_t>(j)].continuous ? shorter_turn(d) : d;
}

PathShortener::Status PathShortener::begin(CollisionWorld& world, const JointVector* prefix, const std::vector<JointVector>& path,
                                           const JointVector& step, std::size_t first, bool shorten) noexcept {
  world_ = &world;
  step_ = step;
  size_ = 0;
  chunks_ = 0;
  trying_ = false;
  truncated_ = (prefix ? 1 : 0) + path.size() > capacity_;
  nodes_.clear();
  source_.clear();
  if (truncated_) return status_ = Status::Done;
  if (prefix) {
    nodes_.push_back(*prefix);
    source_.push_back(-1);
  }
  for (std::size_t i = 0; i < path.size(); ++i) {
    nodes_.push_back(path[i]);
    source_.push_back(static_cast<int>(i));
  }
  size_ = nodes_.size();
  first_ = first;
  i_ = first;
  k_ = size_ > 0 ? size_ - 1 : 0;
  phase_ = Phase::Shortcut;
  return status_ = shorten && size_ >= 2 ? Status::Running : Status::Done;
}

void PathShortener::plan_stairs() noexcept {
  const int n = world_->model().dof();
  const JointVector& from = nodes_[i_];
  const JointVector& to = nodes_[k_];
  order_count_ = 0;
  if (phase_ == Phase::Shortcut) {
    // The order in which the joints first move along the stretch.
    for (std::size_t e = i_; e < k_; ++e) {
      for (int j = 0; j < n; ++j) {
        if (delta(j, nodes_[e], nodes_[e + 1]) == 0.0 || delta(j, from, to) == 0.0) continue;
        if (std::find(base_.begin(), base_.begin() + order_count_, j) == base_.begin() + order_count_) base_[static_cast<std::size_t>(order_count_++)] = j;
      }
    }
  } else {
    for (int j = 0; j < n; ++j) {
      if (delta(j, from, to) != 0.0) base_[static_cast<std::size_t>(order_count_++)] = j;
    }
    // The largest move first: insertion sort, stable and without the buffer std::stable_sort may
    // allocate.
    for (int a = 1; a < order_count_; ++a) {
      const int j = base_[static_cast<std::size_t>(a)];
      int b = a;
      for (; b > 0 && std::abs(delta(base_[static_cast<std::size_t>(b - 1)], from, to)) < std::abs(delta(j, from, to)); --b) {
        base_[static_cast<std::size_t>(b)] = base_[static_cast<std::size_t>(b - 1)];
      }
      base_[static_cast<std::size_t>(b)] = j;
    }
  }
  for (int s = 0; s < order_count_; ++s) perm_[static_cast<std::size_t>(s)] = s;
  orders_tried_ = 1;
  build_stairs();
}

void PathShortener::build_stairs() noexcept {
  const JointVector& to = nodes_[k_];
  for (int s = 0; s < order_count_; ++s) {
    const auto k = static_cast<std::size_t>(s);
    order_[k] = base_[static_cast<std::size_t>(perm_[k])];
    stairs_[k] = s == 0 ? nodes_[i_] : stairs_[k - 1];
    stairs_[k][order_[k]] = to[order_[k]];
  }
}

bool PathShortener::next_order(int blocked) noexcept {
  if (orders_tried_ >= max_orders_) return false;
  const auto begin = perm_.begin();
  const auto end = perm_.begin() + order_count_;
  // Every order that begins as this one up to the blocked stair is blocked there too: the
  // lexicographically last of them comes next, then the next permutation leaves that prefix.
  std::sort(begin + blocked + 1, end, std::greater<>());
  const std::array<int, 16> before = perm_;
  if (!std::next_permutation(begin, end)) return false;
  ++orders_tried_;
  int first_new = 0;
  while (first_new < order_count_ && perm_[static_cast<std::size_t>(first_new)] == before[static_cast<std::size_t>(first_new)]) ++first_new;
  build_stairs();
  // The stairs before the first that differs are the same and were validated.
  stair_ = first_new;
  at_ = first_new == 0 ? nodes_[i_] : stairs_[static_cast<std::size_t>(first_new - 1)];
  return true;
}

bool PathShortener::next_candidate() noexcept {
  for (;;) {
    if (phase_ == Phase::Shortcut) {
      if (i_ + 2 >= size_) {
        phase_ = Phase::Stairs;
        i_ = first_;
        continue;
      }
      if (k_ < i_ + 2) {
        ++i_;
        k_ = size_ - 1;
        continue;
      }
      plan_stairs();
      if (order_count_ == 0 || static_cast<std::size_t>(order_count_) < k_ - i_) return true;
      --k_;
    } else {
      if (i_ + 1 >= size_) return false;
      k_ = i_ + 1;
      plan_stairs();
      if (order_count_ >= 2 && size_ + static_cast<std::size_t>(order_count_) - 1 <= capacity_) return true;
      ++i_;
    }
  }
}

void PathShortener::apply() noexcept {
  const auto m = static_cast<std::size_t>(order_count_);  // nodes after i_ in the replacement
  const std::size_t replaced = k_ - i_;
  end_ = nodes_[k_];
  const int end_source = source_[k_];
  // A loop back to node i_ itself (m = 0) drops the stretch and node k_ with it.
  const std::size_t kept_end = m == 0 ? 0 : 1;
  const std::size_t new_k = i_ + m;
  if (m < replaced) {
    for (std::size_t t = k_ + 1; t < size_; ++t) {
      nodes_[t - (replaced - m)] = nodes_[t];
      source_[t - (replaced - m)] = source_[t];
    }
  } else if (m > replaced) {
    nodes_.resize(size_ + (m - replaced));
    source_.resize(size_ + (m - replaced));
    for (std::size_t t = size_; t-- > k_ + 1;) {
      nodes_[t + (m - replaced)] = nodes_[t];
      source_[t + (m - replaced)] = source_[t];
    }
  }
  size_ = size_ - replaced + m;
  nodes_.resize(size_);
  source_.resize(size_);
  for (std::size_t s = 0; s + 1 < m; ++s) {
    nodes_[i_ + 1 + s] = stairs_[s];
    source_[i_ + 1 + s] = -1;
  }
  if (kept_end) {
    nodes_[new_k] = end_;
    source_[new_k] = end_source;
  }
}

PathShortener::Status PathShortener::step(int budget) noexcept {
  while (status_ == Status::Running && budget > 0) {
    if (!trying_) {
      if (!next_candidate()) return status_ = Status::Done;
      if (order_count_ == 0) {
        apply();  // the stretch returns to where it began
        k_ = size_ - 1;
        continue;
      }
      trying_ = true;
      stair_ = 0;
      at_ = nodes_[i_];
    }
    // One chunk of the stair being validated.
    const int j = order_[static_cast<std::size_t>(stair_)];
    const JointVector& stair_end = stairs_[static_cast<std::size_t>(stair_)];
    const double remaining = delta(j, at_, stair_end);
    const double bound = world_->model().displacement_bound(j);
    const double chunk = bound > 0.0 ? chunk_m_ / bound : std::abs(remaining);
    const bool last_chunk = std::abs(remaining) <= chunk;
    chunk_to_ = at_;
    if (last_chunk) {
      chunk_to_[j] = stair_end[j];
    } else {
      chunk_to_[j] = at_[j] + std::copysign(chunk, remaining);
      if (world_->model().joints()[static_cast<std::size_t>(j)].continuous) chunk_to_[j] = std::remainder(chunk_to_[j], 2.0 * std::numbers::pi);
    }
    --budget;
    ++chunks_;
    if (!world_->validate_edge(at_, chunk_to_, step_).valid()) {
      if (next_order(stair_)) continue;
      trying_ = false;
      if (phase_ == Phase::Shortcut) {
        --k_;
      } else {
        ++i_;
      }
      continue;
    }
    at_ = chunk_to_;
    if (!last_chunk) continue;
    if (++stair_ < order_count_) continue;
    // Every stair is valid.
    trying_ = false;
    apply();
    if (phase_ == Phase::Shortcut) {
      ++i_;
      k_ = size_ - 1;
    } else {
      i_ += static_cast<std::size_t>(order_count_);
    }
  }
  return status_;
}

}  // namespace mgc::planning
