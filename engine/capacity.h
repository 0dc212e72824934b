#pragma once
// Growth policy of the contact arrays: an eighth of headroom past the need, not std::vector's
// doubling. Contact counts creep up as a bed settles, and doubling would keep up to twice the
// memory in use; an eighth still makes regrowth rare (a few times over a run).
#include <cstddef>
#include <vector>

namespace dem {

template <class T>
void resize_with_headroom(std::vector<T>& v, std::size_t n) {
  if (n > v.capacity()) v.reserve(n + n / 8);
  v.resize(n);
}

}  // namespace dem
