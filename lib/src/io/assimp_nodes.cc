// The Assimp node tree shared by the Assimp readers (assimp_nodes.h).
#include "assimp_nodes.h"

#include "importer_internal.h"

namespace skinspheres::lib::detail {

Mat4f ToMat4f(const aiMatrix4x4& m) {
  Mat4f e;
  e << m.a1, m.a2, m.a3, m.a4, m.b1, m.b2, m.b3, m.b4, m.c1, m.c2, m.c3, m.c4, m.d1, m.d2, m.d3, m.d4;
  return e;
}

int32_t AssimpNodeTree::Find(const aiString& name) const {
  const auto it = node_of_name.find(name.C_Str());
  return it == node_of_name.end() ? -1 : it->second;
}

Result<AssimpNodeTree> ReadAssimpNodeTree(const aiScene& scene, const std::filesystem::path& file) {
  AssimpNodeTree tree;
  std::map<const aiNode*, int32_t> index_of;
  std::vector<std::pair<const aiNode*, int32_t>> stack = {{scene.mRootNode, -1}};
  while (!stack.empty()) {
    auto [n, p] = stack.back();
    stack.pop_back();
    if (n == nullptr || index_of.count(n)) continue;
    const Mat4f m = ToMat4f(n->mTransformation);
    if (!m.allFinite()) {
      return ImportError(ErrorCode::kInvalidData, file,
                         "node '" + std::string(n->mName.C_Str()) + "' has a non-finite transform");
    }
    const int32_t index = static_cast<int32_t>(tree.nodes.size());
    index_of[n] = index;
    tree.nodes.push_back(n);
    tree.parent.push_back(p);
    tree.local.push_back(skinning::Transform::FromMatrix(m));
    tree.node_of_name.emplace(n->mName.C_Str(), index);
    for (unsigned c = n->mNumChildren; c-- > 0;) stack.push_back({n->mChildren[c], index});
  }
  return tree;
}

}  // namespace skinspheres::lib::detail
