import * as THREE from 'three';
import { mergeGeometries, mergeVertices } from 'three/addons/utils/BufferGeometryUtils.js';

// At the lowest quality level each link is drawn as one mesh: its parts'
// (simplified) geometries in the link's frame, merged, coloured per vertex.
// Software WebGL pays for every draw call, and the links of the arms people
// bring have several parts each (the demo cell: 45 draws become 15).

const _toLink = new THREE.Matrix4();
const _part = new THREE.Matrix4();

/**
 * One geometry for the parts of a link (`node`, its Object3D): `parts` are
 * `[mesh, geometry, color]` with `mesh` somewhere below `node`; `geometry` replaces the mesh's own (its
 * simplified copy). Positions, normals and colours only; null without parts.
 */
function mergedLinkGeometry( node, parts ) {

	if ( parts.length === 0 ) return null;
	node.updateWorldMatrix( true, true );
	_toLink.copy( node.matrixWorld ).invert();
	const pieces = parts.map( ( [ mesh, geometry, color ] ) => {

		const flat = geometry.index ? geometry.toNonIndexed() : geometry;
		const piece = new THREE.BufferGeometry();
		piece.setAttribute( 'position', flat.attributes.position.clone() );
		if ( flat.attributes.normal ) piece.setAttribute( 'normal', flat.attributes.normal.clone() );
		else piece.computeVertexNormals();
		piece.applyMatrix4( _part.multiplyMatrices( _toLink, mesh.matrixWorld ) );
		const colors = new Float32Array( piece.attributes.position.count * 3 );
		for ( let i = 0; i < colors.length; i += 3 ) colors.set( [ color.r, color.g, color.b ], i );
		piece.setAttribute( 'color', new THREE.BufferAttribute( colors, 3 ) );
		if ( flat !== geometry ) flat.dispose();
		return piece;

	} );
	const merged = mergeGeometries( pieces );
	for ( const piece of pieces ) piece.dispose();
	// Indexed again, vertices shared where position, normal and colour agree: SwiftShader
	// then transforms and lights each once, not once per triangle that uses it (the demo
	// cell: 46 452 vertices become 10 538; bench/page_trace.py, a few ms per frame).
	const indexed = mergeVertices( merged );
	merged.dispose();
	return indexed;

}

export { mergedLinkGeometry };
